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
    radius_eff, mass_eff = pair_size(diameter, density, wall)
    k_n = hertz_secant_stiffness(
        REFERENCE_LOAD_WEIGHTS * mass * GRAVITY,
        radius_eff,
        effective_modulus(youngs_modulus, poisson_ratio),
    )
    k_roll = 2.25 * k_n * rolling_friction**2
    return k_roll, damping_ratio * 2.0 * math.sqrt(mass_eff * k_roll)


def bond_number(surface_energy: float, diameter: float, density: float) -> float:
    """Granular Bond number: the JKR pull-off force of two equal spheres over one's weight.

    Pull-off 3 pi gamma R* with R* = d / 4 (as LAMMPS' JKR model writes it), weight
    rho g pi d^3 / 6: Bo = 9 gamma / (2 rho g d^2). Above about 1 adhesion holds
    particles against their weight: the material is cohesive.
    """
    return 9.0 * surface_energy / (2.0 * density * GRAVITY * diameter**2)


def pair_size(diameter: float, density: float, wall: bool) -> tuple[float, float]:
    """Effective radius R* [m] and mass m* [kg] of a contact of spheres of ``diameter``: R/2
    and m/2 between two, R and m with a wall."""
    mass = density * math.pi / 6.0 * diameter**3
    return (diameter / 2.0, mass) if wall else (diameter / 4.0, mass / 2.0)


def jkr_contact_radius(surface_energy: float, effective_radius: float, modulus: float) -> float:
    """Radius [m] of a JKR contact at zero load: a0 = (9 pi gamma R*^2 / E*)^(1/3).

    Johnson, Kendall & Roberts (1971) as LAMMPS writes them (the force
    4 E* a^3 / (3 R*) - 2 pi a^2 sqrt(4 gamma E* / (pi a)) vanishes there);
    ``modulus`` is E* (`effective_modulus`).
    """
    return float((9.0 * math.pi * surface_energy * effective_radius**2 / modulus) ** (1.0 / 3.0))


def jkr_viscoelastic_damping(
    restitution: float,
    diameter: float,
    density: float,
    youngs_modulus: float,
    poisson_ratio: float,
    surface_energy: float,
    wall: bool,
) -> float:
    """LAMMPS' ``damping viscoelastic`` prefactor eta_n0 [1/(s m)] for a restitution e with JKR.

    LAMMPS' exact restitution damping refuses adhesive contacts; its viscoelastic damping
    eta_n = eta_n0 m* a grows with the contact radius a. eta_n0 is chosen so that a contact
    of spheres of ``diameter`` at rest under adhesion alone (a = a0, `jkr_contact_radius`;
    stiffness k = 2 E* a0) is damped as a linear oscillator of restitution e:
    eta_n = 2 zeta sqrt(m* k), zeta = -ln e / sqrt(pi^2 + ln^2 e).
    """
    radius_eff, mass_eff = pair_size(diameter, density, wall)
    modulus = effective_modulus(youngs_modulus, poisson_ratio)
    contact = jkr_contact_radius(surface_energy, radius_eff, modulus)
    log_e = math.log(restitution)
    zeta = -log_e / math.sqrt(math.pi**2 + log_e**2)
    damping = 2.0 * zeta * math.sqrt(mass_eff * 2.0 * modulus * contact)
    return damping / (mass_eff * contact)
