"""Confined uniaxial compression: a closed-form stand-in, the analytic engine's driver."""

from __future__ import annotations

from typing import Any

from demcal.physics.contact import effective_modulus
from demcal.scenes.base import adhesion, saturating


def analytic_model(p: dict[str, float], settings: dict[str, Any]) -> dict[str, float]:
    """Closed-form stand-in for the test engine: plausible trends, not physics.

    The seated packing loosens with friction and adhesion. Under load the
    constrained modulus follows the effective-medium form of Hertzian packings,
    M = 2 E*^(2/3) sigma^(1/3) (Walton 1987 up to its prefactor), softened
    while loading by the sliding that friction allows, stiffer on unloading;
    the strain at the maximum stress is its integral, 1.5 sigma^(2/3) / (2 E*^(2/3)).
    """
    grip = saturating(p["sliding_friction_pp"], 0.3)
    roll = saturating(p["rolling_friction_pp"], 0.1)
    solid_fraction = 0.63 - 0.03 * grip - 0.07 * roll - 0.08 * adhesion(p, settings)
    stiffness = effective_modulus(p["youngs_modulus"], p["poisson_ratio"]) ** (2.0 / 3.0)
    stress = settings["max_stress"]
    band_stress = 0.5 * (1.0 + settings["modulus_band_lower"]) * stress
    elastic = 2.0 * stiffness * band_stress ** (1.0 / 3.0)
    strain = 1.5 * stress ** (2.0 / 3.0) / (2.0 * stiffness) * (1.0 + 0.5 * (1.0 - grip))
    seated = p["particle_density"] * solid_fraction
    return {
        "seated_bulk_density": seated,
        "compressed_bulk_density": seated / (1.0 - min(strain, 0.5)),
        "loading_modulus": elastic * (0.4 + 0.3 * grip),
        "unloading_modulus": elastic * 1.5,
    }
