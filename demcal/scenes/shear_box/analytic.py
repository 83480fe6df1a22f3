"""Shear box: a closed-form stand-in for the simulation, the analytic engine's driver."""

from __future__ import annotations

from typing import Any

from demcal.scenes.base import saturating


def analytic_model(p: dict[str, float], settings: dict[str, Any]) -> dict[str, float]:
    """Closed-form stand-in for the test engine: smooth, monotone, plausible trends.

    The shear angle rises with sliding and rolling friction (particle-particle
    more than particle-wall) and saturates, falls slightly with restitution
    and rises with the width of the PSD; the packing loosens with friction,
    mostly rolling friction, and packs denser with a wider PSD, after Richter
    & Will's sensitivity findings (sec. 4.1: the angle depends on neither d50
    nor stiffness nor density). Not physics: a known landscape for the
    pipeline and the optimizer.
    """
    grip = saturating(p["sliding_friction_pp"], 0.3)
    roll = saturating(p["rolling_friction_pp"], 0.1)
    spread = settings.get("sigma_ln", 0.0)
    angle = (
        8.0
        + 30.0 * grip * (0.4 + 0.6 * roll)
        + 3.0 * saturating(p["sliding_friction_pw"], 0.3)
        + 2.0 * saturating(p["rolling_friction_pw"], 0.1)
        - 2.0 * (p["restitution_pp"] - 0.5)
        + 4.0 * spread
    )
    solid_fraction = (
        0.63 - 0.03 * grip - 0.07 * roll - 0.01 * (p["restitution_pp"] - 0.5) + 0.04 * spread
    )
    return {"shear_angle": angle, "bulk_density": p["particle_density"] * solid_fraction}
