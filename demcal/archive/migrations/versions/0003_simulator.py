"""What simulated each simulation: the digest of its simulator.

``simulator`` is the sha256 of ``Study.simulator`` (engine, version, the engine settings that
change responses, the files a command reads, the scene's script). Records stored before this
revision did not keep it: they get "" (unknown), and no study reuses them, since demcal
cannot tell which simulator ran them.

Revision ID: 0003
Revises: 0002
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("simulations") as batch:
        batch.add_column(sa.Column("simulator", sa.String(64), nullable=False, server_default=""))
        batch.drop_index("ix_simulations_scene_engine_settings_hash")
        batch.create_index(
            "ix_simulations_scene_engine_simulator_settings_hash",
            ["scene", "engine", "simulator", "settings_hash"],
        )


def downgrade() -> None:
    with op.batch_alter_table("simulations") as batch:
        batch.drop_index("ix_simulations_scene_engine_simulator_settings_hash")
        batch.create_index(
            "ix_simulations_scene_engine_settings_hash", ["scene", "engine", "settings_hash"]
        )
        batch.drop_column("simulator")
