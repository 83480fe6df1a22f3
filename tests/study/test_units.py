"""Small pure functions checked against hand-computed values."""

import math

import numpy as np
import pytest

from demcal.errors import ConfigError
from demcal.optimizer.objective import Target, objective_value, relative_error, replicate_mean
from demcal.physics.contact import (
    effective_modulus,
    hertz_secant_stiffness,
    sds_rolling_coefficients,
)
from demcal.physics.psd import diameter_range, sample_diameters
from demcal.physics.timestep import check_fraction, rayleigh_time


def test_rayleigh_time_hand_value():
    # r = 1 mm, rho = 2500, E = 5e6, nu = 0.3: G = 5e6 / 2.6 = 1.923e6 Pa
    # T_R = pi * 1e-3 * sqrt(2500 / 1.923e6) / (0.1631 * 0.3 + 0.8766) = 1.2239e-4 s
    assert rayleigh_time(1e-3, 2500.0, 5e6, 0.3) == pytest.approx(1.22386e-4, rel=1e-4)


def test_rayleigh_time_scales_with_stiffness():
    soft, stiff = rayleigh_time(1e-3, 2500, 5e6, 0.3), rayleigh_time(1e-3, 2500, 5e8, 0.3)
    assert soft / stiff == pytest.approx(10.0)


def test_timestep_fraction_limits():
    assert check_fraction(0.25, 0.25) is None
    assert "above 0.3" in check_fraction(0.4, 0.25)
    with pytest.raises(ConfigError, match="above 0.5 of the Rayleigh time.*use 0.25 .default"):
        check_fraction(0.6, 0.25)
    with pytest.raises(ConfigError, match="must be > 0"):
        check_fraction(0.0, 0.25)


def test_objective_eq_3_3_hand_value():
    targets = [Target("s", "a", 20.0, weight=1.0), Target("s", "b", 1000.0, weight=2.0)]
    # ((22 - 20) / 20)^2 + 2 ((900 - 1000) / 1000)^2 = 0.01 + 0.02
    assert objective_value(targets, {"s.a": 22.0, "s.b": 900.0}) == pytest.approx(0.03)


def test_zero_target_uses_absolute_error():
    assert relative_error(0.3, 0.0) == pytest.approx(0.3)
    assert relative_error(1.5, 1.0) == pytest.approx(0.5)


def test_replicates_are_averaged_before_the_error():
    target = [Target("s", "a", 10.0)]
    reps = [9.0, 11.0]
    # mean first: error 0; averaging the errors instead would give 0.01
    assert objective_value(target, {"s.a": replicate_mean(reps)}) == pytest.approx(0.0)


def test_lognormal_sample_respects_truncation_and_seed():
    rng = np.random.default_rng(5)
    d = sample_diameters(5000, 2e-3, 0.3, 2.0, rng)
    lo, hi = diameter_range(2e-3, 0.3, 2.0)
    assert d.min() >= lo and d.max() <= hi
    assert np.median(d) == pytest.approx(2e-3, rel=0.03)
    again = sample_diameters(5000, 2e-3, 0.3, 2.0, np.random.default_rng(5))
    assert np.array_equal(d, again)
    assert np.all(sample_diameters(10, 2e-3, 0.0, 2.0, rng) == 2e-3)


def test_hertz_secant_stiffness_round_trip():
    e_star, radius, force = effective_modulus(5e6, 0.3), 0.5e-3, 1e-3
    k = hertz_secant_stiffness(force, radius, e_star)
    overlap = force / k
    assert 4 / 3 * e_star * math.sqrt(radius) * overlap**1.5 == pytest.approx(force)


def test_rolling_stiffness_follows_ai_et_al():
    k_pp, gamma = sds_rolling_coefficients(0.1, 2e-3, 2500, 5e6, 0.3, 0.3, wall=False)
    k_pp2, _ = sds_rolling_coefficients(0.2, 2e-3, 2500, 5e6, 0.3, 0.3, wall=False)
    assert k_pp2 / k_pp == pytest.approx(4.0)  # k_roll ~ mu_r^2
    assert sds_rolling_coefficients(0.0, 2e-3, 2500, 5e6, 0.3, 0.3, wall=True) == (0.0, 0.0)
    # gamma = eta_r 2 sqrt(m* k_roll), m* half a 2 mm sphere's mass
    half_mass = 2500 * math.pi / 6 * 2e-3**3 / 2
    assert gamma == pytest.approx(0.3 * 2 * math.sqrt(half_mass * k_pp))
    _, gamma_rh = sds_rolling_coefficients(0.1, 2e-3, 2500, 5e6, 0.3, 0.25, wall=False)
    assert gamma_rh / gamma == pytest.approx(0.25 / 0.3)


def test_contact_model_reads_each_contact_its_own_restitution_and_rolling_damping():
    """Rackl & Hanley (2017), Table 1: e 0.89 particle-particle, 0.60 particle-wall."""
    from demcal.engines.lammps_driver import contact_model

    p = {
        "youngs_modulus": 5e6,
        "poisson_ratio": 0.22,
        "restitution_pp": 0.89,
        "restitution_pw": 0.6,
        "sliding_friction_pp": 0.2,
        "sliding_friction_pw": 0.3,
        "rolling_friction_pp": 0.05,
        "rolling_friction_pw": 0.04,
        "rolling_damping_ratio": 0.25,
        "surface_energy_pp": 0.0,
        "surface_energy_pw": 0.0,
        "particle_density": 2500.0,
    }
    pair, wall = contact_model(p, {"d50": 5e-3}, False), contact_model(p, {"d50": 5e-3}, True)
    assert pair.startswith("hertz/material 5000000 0.89 0.22 tangential mindlin NULL 1.0 0.2 ")
    assert wall.startswith("hertz/material 5000000 0.6 0.22 tangential mindlin NULL 1.0 0.3 ")
    k_roll, gamma = sds_rolling_coefficients(0.04, 5e-3, 2500.0, 5e6, 0.22, 0.25, wall=True)
    assert f"rolling sds {k_roll:.10g} {gamma:.10g} 0.04 " in wall


def test_cohesionless_contacts_keep_the_hertz_model_and_adhesive_ones_switch_to_jkr():
    from demcal.engines.lammps_driver import contact_model
    from demcal.physics.catalogue import CATALOG
    from demcal.physics.contact import jkr_viscoelastic_damping

    p = {name: spec.default for name, spec in CATALOG.items()}
    assert contact_model(p, {"d50": 2e-3}, False) == (
        "hertz/material 5000000 0.5 0.3 tangential mindlin NULL 1.0 0.5 rolling sds "
        + " ".join(
            f"{v:.10g}" for v in sds_rolling_coefficients(0.1, 2e-3, 2500, 5e6, 0.3, 0.3, False)
        )
        + " 0.1 twisting marshall damping coeff_restitution"
    )
    cohesive = {**p, "surface_energy_pw": 0.2}
    assert contact_model(cohesive, {"d50": 2e-3}, False) == contact_model(p, {"d50": 2e-3}, False)
    eta = jkr_viscoelastic_damping(0.5, 2e-3, 2500.0, 5e6, 0.3, 0.2, wall=True)
    assert contact_model(cohesive, {"d50": 2e-3}, True).startswith(
        f"jkr 5000000 {eta:.10g} 0.3 0.2 tangential mindlin NULL 1.0 0.5 "
    )
    assert contact_model(cohesive, {"d50": 2e-3}, True).endswith(" damping viscoelastic")


def test_jkr_contact_at_zero_load_and_its_damping():
    """The JKR force (as LAMMPS writes it) vanishes at a0; eta_n0 m* a0 damps the contact's
    linear oscillation at the restitution asked for."""
    from demcal.physics.contact import (
        bond_number,
        effective_modulus,
        jkr_contact_radius,
        jkr_viscoelastic_damping,
        pair_size,
    )

    radius, mass = pair_size(2e-3, 2500.0, wall=False)
    modulus = effective_modulus(5e6, 0.3)
    a0 = jkr_contact_radius(0.1, radius, modulus)
    force = 4 * modulus * a0**3 / (3 * radius) - 2 * math.pi * a0**2 * math.sqrt(
        4 * 0.1 * modulus / (math.pi * a0)
    )
    assert abs(force) < 1e-12 * (4 * modulus * a0**3 / (3 * radius))
    eta = jkr_viscoelastic_damping(0.5, 2e-3, 2500.0, 5e6, 0.3, 0.1, wall=False)
    stiffness, damping = 2 * modulus * a0, eta * mass * a0
    zeta = damping / (2 * math.sqrt(mass * stiffness))
    # a linear oscillator of damping ratio zeta rebounds at exp(-pi zeta / sqrt(1 - zeta^2))
    assert math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)) == pytest.approx(0.5)
    # 2 mm glass beads at 0.1 J/m^2: the pull-off force is 4.6 times a bead's weight
    assert bond_number(0.1, 2e-3, 2500.0) == pytest.approx(9 * 0.1 / (2 * 2500 * 9.81 * 4e-6))


def test_adhesion_shortens_the_time_step_only_where_its_contacts_are_stiffer():
    from types import SimpleNamespace

    from demcal.engines.particles import simulation_particles
    from demcal.physics.catalogue import CATALOG
    from demcal.physics.timestep import JKR_STEPS_PER_CONTACT, jkr_contact_time

    p = {name: spec.default for name, spec in CATALOG.items()}
    settings = {"particle_count": 10, "d50": 2e-3, "sigma_ln": 0.0, "psd_truncation": 2.0}

    def step(**given):
        job = SimpleNamespace(parameters={**p, **given}, settings=settings, timestep_fraction=0.25)
        return simulation_particles(job, np.random.default_rng(0)).timestep

    rayleigh_step = 0.25 * rayleigh_time(1e-3, 2500.0, 5e6, 0.3)
    assert step() == step(surface_energy_pp=0.01) == pytest.approx(rayleigh_step)
    strong = jkr_contact_time(1e-3, 2500.0, 5e6, 0.3, 10.0) / JKR_STEPS_PER_CONTACT
    assert strong < rayleigh_step
    assert step(surface_energy_pw=10.0) == pytest.approx(strong)
    assert jkr_contact_time(1e-3, 2500.0, 5e6, 0.3, 100.0) < jkr_contact_time(
        1e-3, 2500.0, 5e6, 0.3, 10.0
    )


def test_parameters_of_an_earlier_demcal_are_read_in_todays_names():
    from demcal.physics.catalogue import upgrade_parameters

    earlier = {"sliding_friction_pp": 0.3, "restitution": 0.7}
    assert upgrade_parameters(earlier) == {
        "sliding_friction_pp": 0.3,
        "restitution_pp": 0.7,
        "restitution_pw": 0.7,
        "rolling_damping_ratio": 0.3,
        "surface_energy_pp": 0.0,
        "surface_energy_pw": 0.0,
    }
    today = {
        "restitution_pp": 0.9,
        "restitution_pw": 0.6,
        "rolling_damping_ratio": 0.25,
        "surface_energy_pp": 0.1,
        "surface_energy_pw": 0.0,
    }
    assert upgrade_parameters(today) == today
    assert upgrade_parameters({}) == {}


def test_rayleigh_cost_is_zero_at_the_largest_time_step_and_the_weight_at_the_smallest():
    """Rackl & Hanley (2017) eq. 10 over E in [5e6, 5e8] Pa, rho 2500, nu 0.3."""
    from demcal.physics.timestep import rayleigh_cost, rayleigh_time_range

    bounds = {
        "particle_density": (2500.0, 2500.0),
        "youngs_modulus": (5.0e6, 5.0e8),
        "poisson_ratio": (0.3, 0.3),
    }
    low, high = rayleigh_time_range(bounds)
    assert high / low == pytest.approx(10.0)  # T_R ~ E^-1/2
    soft = {"particle_density": 2500.0, "youngs_modulus": 5.0e6, "poisson_ratio": 0.3}
    stiff = {**soft, "youngs_modulus": 5.0e8}
    middle = {**soft, "youngs_modulus": 5.0e7}  # T_R = high / sqrt(10)
    assert rayleigh_cost(soft, (low, high), 1.0) == pytest.approx(0.0)
    assert rayleigh_cost(stiff, (low, high), 0.5) == pytest.approx(0.5)
    assert rayleigh_cost(middle, (low, high), 1.0) == pytest.approx((1 - 10**-0.5) / (1 - 0.1))


def test_objective_forms_agree_with_eq_3_3():
    """Per replicate and from early estimates, the objective is eq. 3.3 of those values."""
    from demcal.optimizer.objective import estimated_objective, replicate_objectives

    targets = [Target("s", "a", 20.0), Target("s", "b", 1000.0, weight=2.0)]
    replicates = {"s.a": [22.0, 18.0], "s.b": [900.0, 1100.0]}
    assert replicate_objectives(targets, replicates, cost=0.5) == pytest.approx(
        [0.01 + 0.02 + 0.5, 0.01 + 0.02 + 0.5]
    )
    assert replicate_objectives(targets, {"s.a": [22.0], "s.b": [900.0]}) == []
    # only 'a' estimated so far: a lower bound from the mean of its replicates
    assert estimated_objective(targets, {"s.a": [21.0, 23.0]}) == pytest.approx(0.01)
    assert estimated_objective(targets, {}) is None
