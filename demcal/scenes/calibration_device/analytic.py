"""Calibration device: a closed-form stand-in for the simulation, the analytic engine's driver."""

from __future__ import annotations

import math
from typing import Any

from demcal.scenes.base import saturating


def analytic_model(p: dict[str, float], settings: dict[str, Any]) -> dict[str, float]:
    """Closed-form stand-in for the test engine: plausible monotone trends, not physics.

    The mass flow falls with particle friction (Beverloo-like slot flow,
    rho_b sqrt(g) W^1.5 per unit depth); the slide time rises steeply as the
    wall friction approaches tan(slide angle); the pile angle rises with
    both frictions.
    """
    grip_pp = saturating(p["sliding_friction_pp"], 0.4)
    grip_pw = p["sliding_friction_pw"] / math.tan(math.radians(settings["slide_angle"]))
    bulk = 0.6 * p["particle_density"]
    flow = (
        bulk
        * math.sqrt(9.81)
        * settings["orifice_width"] ** 1.5
        * settings["depth"]
        * (0.75 - 0.25 * grip_pp - 0.1 * saturating(p["rolling_friction_pp"], 0.1))
    )
    slide = 0.4 + 0.6 / (1.0 + math.exp(-6.0 * (grip_pw - 0.9)))
    aor = 10.0 + 18.0 * grip_pp + 6.0 * saturating(p["sliding_friction_pw"], 0.4)
    return {"mass_flow": flow, "slide_time": slide, "angle_of_repose": aor}
