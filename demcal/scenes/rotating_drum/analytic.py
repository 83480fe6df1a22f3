"""Rotating drum: a closed-form stand-in for the simulation, the analytic engine's driver."""

from __future__ import annotations

from typing import Any

from demcal.scenes.base import adhesion, saturating
from demcal.scenes.rotating_drum.regime import froude_number


def analytic_model(p: dict[str, float], settings: dict[str, Any]) -> dict[str, float]:
    """Closed-form stand-in for the test engine: plausible monotone trends, not physics.

    The dynamic angle rises with particle sliding and rolling friction (rolling
    friction counting once sliding friction holds), a little with the mantle's
    friction, and with the Froude number across the rolling regime; it falls a
    little with restitution. The interface fluctuates by a fraction of a
    particle diameter, more with friction. Adhesion (its Bond number) raises
    both, the fluctuation most: a cohesive surface moves in lumps.
    """
    grip = saturating(p["sliding_friction_pp"], 0.3)
    roll = saturating(p["rolling_friction_pp"], 0.1)
    cohesion = adhesion(p, settings)
    angle = (
        16.0
        + 22.0 * grip * (0.45 + 0.55 * roll)
        + 3.0 * saturating(p["sliding_friction_pw"], 0.3)
        + 300.0 * froude_number(settings)
        - 1.5 * (p["restitution_pp"] - 0.5)
        + 18.0 * cohesion
    )
    fluctuation = settings["d50"] * (0.2 + 0.15 * grip + 0.15 * roll) * (1.0 + 3.0 * cohesion)
    return {"dynamic_angle_of_repose": angle, "interface_fluctuation": fluctuation}
