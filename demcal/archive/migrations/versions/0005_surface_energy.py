"""Adhesion: the surface energies of JKR contacts join every simulation's material.

Every simulation that recorded its parameters gets ``surface_energy_pp`` and
``surface_energy_pw`` of 0 J/m^2, the cohesionless contacts earlier versions ran (one that
failed on its parameters, and recorded no material, stays without); ``key`` is spelled again over
them (``demcal.archive.simulation.ArchivedSimulation.provenance``), so a study folder
imported before and imported again is still stored once.

Revision ID: 0005
Revises: 0004
"""

import hashlib
import json

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None

#: What this revision adds; fixed here, whatever later versions of demcal declare.
ADDED = {"surface_energy_pp": (0.0, "J/m^2"), "surface_energy_pw": (0.0, "J/m^2")}

simulations = sa.table(
    "simulations",
    sa.column("id", sa.Integer),
    sa.column("key", sa.String),
    sa.column("simulator", sa.String),
    sa.column("study", sa.String),
    sa.column("evaluation", sa.String),
    sa.column("scene", sa.String),
    sa.column("replicate", sa.Integer),
    sa.column("attempt", sa.Integer),
    sa.column("seed", sa.BigInteger),
    sa.column("engine", sa.String),
    sa.column("engine_version", sa.String),
    sa.column("settings", sa.JSON),
    sa.column("timestep_fraction", sa.Double),
)
parameters = sa.table(
    "parameters",
    sa.column("simulation_id", sa.Integer),
    sa.column("name", sa.String),
    sa.column("value", sa.Double),
    sa.column("unit", sa.String),
    sa.column("free", sa.Boolean),
)


def digest(value: object) -> str:
    """sha256 of a JSON value in one canonical spelling, as the archive spells its keys."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def upgrade() -> None:
    connection = op.get_bind()
    values: dict[int, dict[str, float]] = {}
    for row in connection.execute(sa.select(parameters)):
        values.setdefault(row.simulation_id, {})[row.name] = row.value
    for sim in connection.execute(sa.select(simulations)).all():
        old, settings = values.get(sim.id, {}), sim.settings
        added = {name: value for name, value in ADDED.items() if name not in old}
        if not added or all(name in settings for name in old):  # there, or no material
            continue
        connection.execute(
            sa.insert(parameters),
            [
                {"simulation_id": sim.id, "name": n, "value": v, "unit": u, "free": False}
                for n, (v, u) in added.items()
            ],
        )
        every = {**old, **{name: value for name, (value, _) in added.items()}}
        provenance = ({"simulator": sim.simulator} if sim.simulator else {}) | {
            "study": sim.study,
            "evaluation": sim.evaluation,
            "scene": sim.scene,
            "replicate": sim.replicate,
            "attempt": sim.attempt,
            "seed": sim.seed,
            "engine": sim.engine,
            "engine_version": sim.engine_version,
            "settings": settings,
            "timestep_fraction": sim.timestep_fraction,
            "parameters": {n: v for n, v in every.items() if n not in settings},
        }
        connection.execute(
            sa.update(simulations).where(simulations.c.id == sim.id).values(key=digest(provenance))
        )


def downgrade() -> None:
    """Refused: a simulation with adhesion has no cohesionless counterpart in the earlier
    schema."""
    raise RuntimeError("the archive's fifth schema cannot be taken back to the fourth")
