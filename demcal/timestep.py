"""Time step of a DEM simulation from the Rayleigh time (Rackl & Hanley 2017, eq. 1)."""

from __future__ import annotations

import math

from demcal.errors import ConfigError

#: Default time step as a fraction of the Rayleigh time (Rackl & Hanley 2017).
DEFAULT_FRACTION = 0.25
#: Above this fraction the log gets a warning: results start to drift.
WARN_FRACTION = 0.3
#: Above this fraction the study is refused (measured: 0.5 already 5-7 % too
#: dense in one study, 0.75 ran but gave wrong results, >= 0.75 often blows up).
MAX_FRACTION = 0.5


def shear_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """G = E / (2 (1 + nu)) [Pa]."""
    return youngs_modulus / (2.0 * (1.0 + poisson_ratio))


def rayleigh_time(radius: float, density: float, youngs_modulus: float,
                  poisson_ratio: float) -> float:
    """Rayleigh time [s] of a sphere: T_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766).

    Rackl & Hanley (2017), eq. 1; use the smallest radius of the packing.
    """
    g = shear_modulus(youngs_modulus, poisson_ratio)
    return math.pi * radius * math.sqrt(density / g) / (0.1631 * poisson_ratio + 0.8766)


def check_fraction(fraction: float, field: str = "timestep_fraction") -> str | None:
    """Refuse an unsafe fraction of the Rayleigh time; return a warning text or None."""
    if not (fraction > 0.0):
        raise ConfigError(f"{field}: {fraction!r} must be > 0 (default {DEFAULT_FRACTION})")
    if fraction > MAX_FRACTION:
        raise ConfigError(
            f"{field}: {fraction:g} is above {MAX_FRACTION:g} of the Rayleigh time. "
            f"Larger steps run but give wrong results (measured: 0.5 already packs "
            f"5-7 % too dense, 0.75 and above lose particles); use {DEFAULT_FRACTION:g} "
            f"(default) up to {MAX_FRACTION:g}.")
    if fraction > WARN_FRACTION:
        return (f"{field}: {fraction:g} of the Rayleigh time is above {WARN_FRACTION:g}; "
                f"check the responses against a run at {DEFAULT_FRACTION:g}")
    return None


def timestep(fraction: float, radius_min: float, density: float,
             youngs_modulus: float, poisson_ratio: float) -> float:
    """Time step [s] = fraction * T_R of the smallest, softest particle."""
    return fraction * rayleigh_time(radius_min, density, youngs_modulus, poisson_ratio)
