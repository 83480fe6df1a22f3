"""Restitution per contact, the rolling damping ratio, and the variable settings as parameters.

The tables keep their columns; the rows change to what demcal records from this revision on:

- a ``restitution`` row becomes ``restitution_pp`` and ``restitution_pw`` of its value (earlier
  versions used one coefficient for every contact);
- a simulation without ``rolling_damping_ratio`` gets 0.3, the constant earlier versions ran
  (one that failed on its parameters, and recorded none, stays without);
- the variable scene settings (``d50``, ``sigma_ln``) get parameter rows from the settings;
- ``settings_hash`` then covers the other settings only, and ``key`` is spelled again over
  the renamed parameters (``demcal.archive.simulation.ArchivedSimulation``), so a study folder
  imported before and imported again is still stored once.

Revision ID: 0002
Revises: 0001
"""

import hashlib
import json

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None

#: What this revision changes; fixed here, whatever later versions of demcal declare.
SPLIT = {"restitution": ("restitution_pp", "restitution_pw")}
EARLIER_ROLLING_DAMPING_RATIO = 0.3
VARIABLE_SETTINGS = {"d50": "m", "sigma_ln": "-"}

simulations = sa.table(
    "simulations",
    sa.column("id", sa.Integer),
    sa.column("key", sa.String),
    sa.column("study", sa.String),
    sa.column("evaluation", sa.String),
    sa.column("scene", sa.String),
    sa.column("replicate", sa.Integer),
    sa.column("attempt", sa.Integer),
    sa.column("seed", sa.BigInteger),
    sa.column("engine", sa.String),
    sa.column("engine_version", sa.String),
    sa.column("settings", sa.JSON),
    sa.column("settings_hash", sa.String),
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
    rows: dict[int, dict[str, tuple[float, str, bool]]] = {}
    for row in connection.execute(sa.select(parameters)):
        rows.setdefault(row.simulation_id, {})[row.name] = (row.value, row.unit, row.free)
    for sim in connection.execute(sa.select(simulations)).all():
        old = rows.get(sim.id, {})
        new = {name: value for name, value in old.items() if name not in SPLIT}
        for name, parts in SPLIT.items():
            if name in old:
                new.update({part: old[name] for part in parts if part not in old})
        if old:  # a run that failed on its parameters recorded none, then as now
            new.setdefault("rolling_damping_ratio", (EARLIER_ROLLING_DAMPING_RATIO, "-", False))
        settings = sim.settings
        for name, unit in VARIABLE_SETTINGS.items():
            if name in settings and name not in new:
                new[name] = (float(settings[name]), unit, False)
        provenance = {
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
            "parameters": {n: v[0] for n, v in new.items() if n not in settings},
        }
        connection.execute(
            sa.update(simulations)
            .where(simulations.c.id == sim.id)
            .values(
                key=digest(provenance),
                settings_hash=digest({n: v for n, v in settings.items() if n not in new}),
            )
        )
        connection.execute(sa.delete(parameters).where(parameters.c.simulation_id == sim.id))
        connection.execute(
            sa.insert(parameters),
            [
                {"simulation_id": sim.id, "name": n, "value": v, "unit": u, "free": f}
                for n, (v, u, f) in new.items()
            ],
        )


def downgrade() -> None:
    """Refused: the first schema has one restitution, and two that differ cannot be merged."""
    raise RuntimeError("the archive's second schema cannot be taken back to the first")
