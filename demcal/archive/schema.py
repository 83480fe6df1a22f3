"""The archive's tables (SQLAlchemy 2.0 declarative models).

``simulations`` holds one row per simulation with its provenance, status and cost;
``parameters`` and ``responses`` one row per value, with its unit. Values are rows rather
than JSON so that "every simulation of this scene whose restitution is 0.5" is a plain join
in SQLite and PostgreSQL alike; the scene settings, the particle-size distribution and the
engine's full cost figures, read whole, are JSON. ``simulator`` and ``settings_hash`` index
what simulated it and its settings for the search of compatible simulations
(:meth:`demcal.archive.Archive.compatible`).

The migrations in ``demcal/archive/migrations/versions`` build these tables; a change here
needs a new migration there (tests/archive checks that they agree).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    CheckConstraint,
    Double,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    String,
    Text,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from demcal.results.records import ENDED

#: Names of constraints and indexes, the same in SQLite and PostgreSQL and in the migrations.
NAMING = {
    "ix": "ix_%(table_name)s_%(column_0_N_name)s",
    "uq": "uq_%(table_name)s_%(column_0_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING)


class SimulationRow(Base):
    """One simulation: where it came from, what it ran, how it ended, what it cost."""

    __tablename__ = "simulations"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    #: sha256 of the provenance (demcal.archive.simulation.ArchivedSimulation.key): one row each
    key: Mapped[str] = mapped_column(String(64), unique=True)
    study: Mapped[str] = mapped_column(String(200))
    evaluation: Mapped[str] = mapped_column(String(200))
    scene: Mapped[str] = mapped_column(String(100))
    replicate: Mapped[int] = mapped_column(Integer)
    attempt: Mapped[int | None] = mapped_column(Integer)
    seed: Mapped[int | None] = mapped_column(BigInteger)
    engine: Mapped[str] = mapped_column(String(100))
    engine_version: Mapped[str] = mapped_column(String(200))
    settings: Mapped[dict[str, Any]] = mapped_column(JSON)
    settings_hash: Mapped[str] = mapped_column(String(64))
    #: {setting: {"value", "unit"}} of the particle-size distribution among the settings
    psd: Mapped[dict[str, Any]] = mapped_column(JSON)
    timestep_fraction: Mapped[float] = mapped_column(Double)
    status: Mapped[str] = mapped_column(String(16))
    reason: Mapped[str] = mapped_column(Text)
    cpu_s: Mapped[float | None] = mapped_column(Double)
    wall_s: Mapped[float | None] = mapped_column(Double)
    particle_steps: Mapped[float | None] = mapped_column(Double)
    #: every figure the engine reported (cpu_s, wall_s, steps, particle_steps, ...)
    cost: Mapped[dict[str, Any]] = mapped_column(JSON)
    started_at: Mapped[float | None] = mapped_column(Double)
    ended_at: Mapped[float | None] = mapped_column(Double)
    recorded_at: Mapped[float] = mapped_column(Double)
    #: "job" (written by the evaluation's archive job) or "import" (demcal archive import)
    source: Mapped[str] = mapped_column(String(16))
    demcal_version: Mapped[str] = mapped_column(String(50))
    #: sha256 of what simulated it (``Study.simulator``); "" where unknown (never reused)
    simulator: Mapped[str] = mapped_column(String(64), server_default="")
    #: the study's fidelity level it ran at ("fine": the study's own settings)
    fidelity: Mapped[str] = mapped_column(String(64), server_default="fine")
    #: sha256 of the fine level it belongs to (``Study.fine_level_view``); "" where unknown
    fine_level: Mapped[str] = mapped_column(String(64), server_default="")

    __table_args__ = (
        CheckConstraint(f"status IN ({', '.join(map(repr, map(str, ENDED)))})", name="status"),
        Index(None, "scene", "engine", "simulator", "settings_hash"),
        Index(None, "study", "evaluation"),
    )


class _Value:
    """Columns of a named value of a simulation, in ``unit``."""

    simulation_id: Mapped[int] = mapped_column(
        ForeignKey("simulations.id", ondelete="CASCADE"), primary_key=True
    )
    name: Mapped[str] = mapped_column(String(100), primary_key=True)
    value: Mapped[float] = mapped_column(Double)
    unit: Mapped[str] = mapped_column(String(32))


class ParameterRow(_Value, Base):
    """A material parameter of a simulation, free (varied by its study) or fixed, in SI."""

    __tablename__ = "parameters"

    free: Mapped[bool] = mapped_column(Boolean)

    __table_args__ = (Index(None, "name", "value"),)


class ResponseRow(_Value, Base):
    """A response of a simulation: its final value, or for a stopped run its last estimate
    (``final`` says whether that estimate could still change)."""

    __tablename__ = "responses"

    final: Mapped[bool] = mapped_column(Boolean)
