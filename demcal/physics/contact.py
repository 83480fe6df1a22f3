"""Contact-model conversions between the papers' parameters and an engine's inputs.

"Rolling friction" differs between codes. Rackl & Hanley (2017) use the
elastic-plastic spring-dashpot model of Ai et al. (2011): rolling stiffness
k_r = 2.25 k_n mu_r^2 R*^2 [N m/rad], torque capped at mu_r R* F_n, viscous
damping eta_r 2 sqrt(I_r k_r). LAMMPS' ``rolling sds`` puts a spring k_roll
[N/m] on the rolling displacement (R* times the rolling angle) and caps the
force at mu_roll F_n, so the same torque law needs k_roll = 2.25 k_n mu_r^2
with a constant reference normal stiffness k_n.
"""

from __future__ import annotations

import math

#: Reference contact load, in particle weights, for the secant normal stiffness.
REFERENCE_LOAD_WEIGHTS = 10.0
GRAVITY = 9.81


def effective_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """E* [Pa] of a contact between two bodies of the same material: E / (2 (1 - nu^2))."""
    return youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))


def hertz_secant_stiffness(force: float, effective_radius: float, effective_mod: float) -> float:
    """Secant normal stiffness F / delta [N/m] of a Hertz contact under load ``force`` [N].

    Hertz: F = 4/3 E* sqrt(R*) delta^(3/2).
    """
    # float ** float is typed Any (a negative base gives a complex); the load is positive
    overlap: float = (3.0 * force / (4.0 * effective_mod * math.sqrt(effective_radius))) ** (
        2.0 / 3.0
    )
    return force / overlap


def sds_rolling_coefficients(
    rolling_friction: float,
    diameter: float,
    density: float,
    youngs_modulus: float,
    poisson_ratio: float,
    damping_ratio: float,
    wall: bool,
) -> tuple[float, float]:
    """LAMMPS ``rolling sds`` stiffness [N/m] and damping [N s/m] for a rolling friction mu_r.

    Follows Ai et al. (2011) as used by Rackl & Hanley (2017): k_roll = 2.25 k_n mu_r^2,
    k_n the Hertz secant stiffness at ``REFERENCE_LOAD_WEIGHTS`` particle weights
    (measured: the choice of load changes results by less than the noise);
    damping gamma = eta_r 2 sqrt(m* k_roll) with eta_r the ``damping_ratio``
    (Ai et al. recommend 0.3; Rackl & Hanley's Table 1 fixes 0.25). A wall contact has
    R* = R and m* = m, a particle pair R* = R/2 and m* = m/2.
    """
    mass = density * math.pi / 6.0 * diameter**3
    radius_eff = diameter / 2.0 if wall else diameter / 4.0
    mass_eff = mass if wall else mass / 2.0
    k_n = hertz_secant_stiffness(
        REFERENCE_LOAD_WEIGHTS * mass * GRAVITY,
        radius_eff,
        effective_modulus(youngs_modulus, poisson_ratio),
    )
    k_roll = 2.25 * k_n * rolling_friction**2
    return k_roll, damping_ratio * 2.0 * math.sqrt(mass_eff * k_roll)
