"""Transfer chute: a closed-form stand-in for the simulation, the analytic engine's driver."""

from __future__ import annotations

import math
from typing import Any

from scipy.stats import norm

from demcal.physics.contact import GRAVITY

#: Spread [m] of the stream across the divider in the stand-in (its sd in y).
STREAM_SD = 0.08


def analytic_model(p: dict[str, float], settings: dict[str, Any]) -> dict[str, float]:
    """Closed-form stand-in for the test engine: a ballistic throw, a funnel that keeps part
    of the stream's offset, and a normal stream cut by the divider. Not physics: it gives the
    pipeline and the optimizer a known landscape with a set of even splits.

    The stream leaves the belt's end at the belt speed and falls to the funnel's top; where it
    lands off the funnel's centre, a share of that offset (less with more wall friction)
    survives the funnel and the tilt moves the outlet. The left share is the normal
    probability that the stream's centre lands left of the divider.
    """
    s = settings
    drop = max(s["belt_height"] - (s["funnel_height"] + s["funnel_z"]), 0.0)
    landing = -s["belt_reach"] + s["belt_speed"] * math.sqrt(2.0 * drop / GRAVITY)
    offset = landing - s["funnel_y"]
    kept = 0.5 * (1.0 - 0.5 * min(p["sliding_friction_pw"], 1.0))
    outlet = s["funnel_y"] + s["funnel_depth"] * math.sin(math.radians(s["funnel_angle"]))
    centre = outlet + kept * offset
    left_share = float(norm.cdf(-centre / STREAM_SD))
    left, right = s["feed_rate"] * left_share, s["feed_rate"] * (1.0 - left_share)
    return {
        "mass_flow_left": left,
        "mass_flow_right": right,
        "flow_difference": left - right,
        "split": left_share,
    }
