"""Cylinder lift: a closed-form stand-in for the simulation, the analytic engine's driver."""

from __future__ import annotations

from typing import Any

from demcal.scenes.base import adhesion, saturating


def analytic_model(p: dict[str, float], settings: dict[str, Any]) -> dict[str, float]:
    """Closed-form stand-in for the test engine: smooth, monotone, plausible trends.

    The angle rises with sliding and rolling friction and saturates; the
    packing loosens with friction, mostly with rolling friction, so that the
    two responses pin the two friction coefficients (a single best point);
    density scales the bulk density. Adhesion (its Bond number) steepens the
    heap and loosens the packing. Not physics: it gives the pipeline and the
    optimizer a known landscape.
    """
    grip = saturating(p["sliding_friction_pp"], 0.35)
    roll = saturating(p["rolling_friction_pp"], 0.08)
    cohesion = adhesion(p, settings)
    aor = (
        4.0
        + 34.0 * grip * (0.35 + 0.65 * roll)
        + 4.0 * saturating(p["sliding_friction_pw"], 0.3)
        + 3.0 * saturating(p["rolling_friction_pw"], 0.1)
        - 2.0 * (p["restitution_pp"] - 0.5)
        + 12.0 * cohesion
    )
    solid_fraction = (
        0.64 - 0.02 * grip - 0.08 * roll - 0.01 * (p["restitution_pp"] - 0.5) - 0.08 * cohesion
    )
    return {"angle_of_repose": aor, "bulk_density": p["particle_density"] * solid_fraction}
