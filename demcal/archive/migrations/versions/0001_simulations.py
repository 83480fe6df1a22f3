"""The first schema: simulations, their parameters and their responses.

Revision ID: 0001
Revises:
"""

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "simulations",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("key", sa.String(64), nullable=False),
        sa.Column("study", sa.String(200), nullable=False),
        sa.Column("evaluation", sa.String(200), nullable=False),
        sa.Column("scene", sa.String(100), nullable=False),
        sa.Column("replicate", sa.Integer(), nullable=False),
        sa.Column("attempt", sa.Integer(), nullable=True),
        sa.Column("seed", sa.BigInteger(), nullable=True),
        sa.Column("engine", sa.String(100), nullable=False),
        sa.Column("engine_version", sa.String(200), nullable=False),
        sa.Column("settings", sa.JSON(), nullable=False),
        sa.Column("settings_hash", sa.String(64), nullable=False),
        sa.Column("psd", sa.JSON(), nullable=False),
        sa.Column("timestep_fraction", sa.Double(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("reason", sa.Text(), nullable=False),
        sa.Column("cpu_s", sa.Double(), nullable=True),
        sa.Column("wall_s", sa.Double(), nullable=True),
        sa.Column("particle_steps", sa.Double(), nullable=True),
        sa.Column("cost", sa.JSON(), nullable=False),
        sa.Column("started_at", sa.Double(), nullable=True),
        sa.Column("ended_at", sa.Double(), nullable=True),
        sa.Column("recorded_at", sa.Double(), nullable=False),
        sa.Column("source", sa.String(16), nullable=False),
        sa.Column("demcal_version", sa.String(50), nullable=False),
        sa.CheckConstraint(
            "status IN ('ok', 'failed', 'terminated')", name="ck_simulations_status"
        ),
        sa.PrimaryKeyConstraint("id", name="pk_simulations"),
        sa.UniqueConstraint("key", name="uq_simulations_key"),
    )
    op.create_index(
        "ix_simulations_scene_engine_settings_hash",
        "simulations",
        ["scene", "engine", "settings_hash"],
    )
    op.create_index("ix_simulations_study_evaluation", "simulations", ["study", "evaluation"])
    for table in ("parameters", "responses"):
        op.create_table(
            table,
            sa.Column("simulation_id", sa.Integer(), nullable=False),
            sa.Column("name", sa.String(100), nullable=False),
            sa.Column("value", sa.Double(), nullable=False),
            sa.Column("unit", sa.String(32), nullable=False),
            sa.Column("free" if table == "parameters" else "final", sa.Boolean(), nullable=False),
            sa.ForeignKeyConstraint(
                ["simulation_id"],
                ["simulations.id"],
                name=f"fk_{table}_simulation_id_simulations",
                ondelete="CASCADE",
            ),
            sa.PrimaryKeyConstraint("simulation_id", "name", name=f"pk_{table}"),
        )
    op.create_index("ix_parameters_name_value", "parameters", ["name", "value"])


def downgrade() -> None:
    op.drop_table("responses")
    op.drop_table("parameters")
    op.drop_index("ix_simulations_study_evaluation", table_name="simulations")
    op.drop_index("ix_simulations_scene_engine_settings_hash", table_name="simulations")
    op.drop_table("simulations")
