"""Time step of a DEM simulation from the Rayleigh time (Rackl & Hanley 2017, eq. 1), and the
shorter one adhesion (JKR) may need."""

from __future__ import annotations

import math

from demcal.errors import ConfigError
from demcal.physics.contact import effective_modulus, jkr_contact_radius, pair_size

#: Above this fraction the log gets a warning: results start to drift.
WARN_FRACTION = 0.3
#: Above this fraction the study is refused (measured: 0.5 already 5-7 % too
#: dense in one study, 0.75 ran but gave wrong results, >= 0.75 often blows up).
MAX_FRACTION = 0.5


def shear_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """G = E / (2 (1 + nu)) [Pa]."""
    return youngs_modulus / (2.0 * (1.0 + poisson_ratio))


def rayleigh_time(
    radius: float, density: float, youngs_modulus: float, poisson_ratio: float
) -> float:
    """Rayleigh time [s] of a sphere: T_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766).

    Rackl & Hanley (2017), eq. 1; use the smallest radius of the packing.
    """
    g = shear_modulus(youngs_modulus, poisson_ratio)
    return math.pi * radius * math.sqrt(density / g) / (0.1631 * poisson_ratio + 0.8766)


#: Material parameters of adhesion, which can shorten the time step (`jkr_contact_time`).
ADHESION_PARAMETERS = ("surface_energy_pp", "surface_energy_pw")
#: Time steps per duration of an adhesive contact's oscillation (`jkr_contact_time`).
JKR_STEPS_PER_CONTACT = 10.0


def jkr_contact_time(
    radius: float,
    density: float,
    youngs_modulus: float,
    poisson_ratio: float,
    surface_energy: float,
) -> float:
    """Duration [s] of a contact between two equal spheres held by JKR adhesion at zero load.

    Half the period of their small oscillation, pi sqrt(m* / k), k = 2 E* a0 the normal
    stiffness of a Hertz contact of the radius a JKR contact has at zero load
    (`jkr_contact_radius`). Adhesion pulls contacts to this radius whatever the load, so it
    can be far stiffer than the loads of a cohesionless packing make it, and the Rayleigh
    time no longer bounds the stable step.
    """
    radius_eff, mass_eff = pair_size(2.0 * radius, density, wall=False)
    modulus = effective_modulus(youngs_modulus, poisson_ratio)
    stiffness = 2.0 * modulus * jkr_contact_radius(surface_energy, radius_eff, modulus)
    return math.pi * math.sqrt(mass_eff / stiffness)


def check_fraction(fraction: float, default: float, field: str = "timestep_fraction") -> str | None:
    """Refuse an unsafe fraction of the Rayleigh time; return a warning text or None.

    ``default`` is the study file's default fraction, recommended in the messages.
    """
    if not (fraction > 0.0):
        raise ConfigError(f"{field}: {fraction!r} must be > 0 (default {default:g})")
    if fraction > MAX_FRACTION:
        raise ConfigError(
            f"{field}: {fraction:g} is above {MAX_FRACTION:g} of the Rayleigh time. "
            f"Larger steps run but give wrong results (measured: 0.5 already packs "
            f"5-7 % too dense, 0.75 and above lose particles); use {default:g} "
            f"(default) up to {MAX_FRACTION:g}."
        )
    if fraction > WARN_FRACTION:
        return (
            f"{field}: {fraction:g} of the Rayleigh time is above {WARN_FRACTION:g}; "
            f"check the responses against a run at {default:g}"
        )
    return None


#: Material parameters the Rayleigh time depends on.
RAYLEIGH_PARAMETERS = ("particle_density", "youngs_modulus", "poisson_ratio")


def rayleigh_time_range(bounds: dict[str, tuple[float, float]]) -> tuple[float, float]:
    """Smallest and largest Rayleigh time per metre of radius [s/m] over a parameter box.

    ``bounds`` gives (lower, upper) of density, Young's modulus and Poisson's
    ratio (equal for a fixed one); T_R is monotone in each, so the extremes
    lie at corners of the box.
    """
    corners = [
        rayleigh_time(1.0, rho, e, nu)
        for rho in bounds["particle_density"]
        for e in bounds["youngs_modulus"]
        for nu in bounds["poisson_ratio"]
    ]
    return min(corners), max(corners)


def rayleigh_cost(
    parameters: dict[str, float], time_range: tuple[float, float], weight: float
) -> float:
    """Rackl & Hanley (2017), eq. 10: W_RL (r_max - dt_R) / (r_max - r_min), in [0, W_RL].

    Zero at the largest Rayleigh time the bounds allow, W_RL at the smallest;
    squared, it joins the relative errors of the responses in the objective,
    steering among equally good parameter sets to the cheapest to simulate.
    """
    low, high = time_range
    if weight == 0.0 or high <= low:
        return 0.0
    time = rayleigh_time(
        1.0,
        parameters["particle_density"],
        parameters["youngs_modulus"],
        parameters["poisson_ratio"],
    )
    return weight * (high - time) / (high - low)
