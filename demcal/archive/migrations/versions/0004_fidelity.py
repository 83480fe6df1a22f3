"""The fidelity level of each simulation, and the fine level it belongs to.

``fidelity`` names the study's level the simulation ran at ("fine": the study's own
settings; docs/fidelity.md); ``fine_level`` is the sha256 of that study's fine level of the
scene (its settings, time-step fraction and simulator: ``Study.fine_level_view``), so that a
coarse simulation can be told which fine simulations it is a cheaper version of. Records
stored before this revision ran at their study's own settings: "fine", and their fine level
is unknown ("").

Revision ID: 0004
Revises: 0003
"""

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("simulations") as batch:
        batch.add_column(
            sa.Column("fidelity", sa.String(64), nullable=False, server_default="fine")
        )
        batch.add_column(sa.Column("fine_level", sa.String(64), nullable=False, server_default=""))


def downgrade() -> None:
    with op.batch_alter_table("simulations") as batch:
        batch.drop_column("fine_level")
        batch.drop_column("fidelity")
