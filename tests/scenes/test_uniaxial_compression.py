"""Confined uniaxial compression: declaration, measures, analytic model, tiny LAMMPS runs.

The LAMMPS tests (marker ``lammps``) compress about 310 spheres of 3 mm in a cylinder of
eight of them to 10 kPa: a few seconds per run.
"""

import helpers
import numpy as np
import pytest
from helpers import (
    COHESIVE_CORNER,
    PARAMETER_CORNERS,
    cohesive_corner_problem,
    run_lammps,
    run_lammps_stopped,
)

from demcal.errors import ConfigError, SimulationFailed
from demcal.physics import measure
from demcal.physics.catalogue import CATALOG
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.uniaxial_compression import fill_particle_count

SCENE = SCENES.load("uniaxial_compression")
DEFAULTS = {name: spec.default for name, spec in CATALOG.items()}


def settings(**given):
    return SCENE.resolve_settings(given, "s")


def test_defaults_fill_the_cylinder():
    # pi 12.5^2 mm^2 x 25 mm at a solid fraction of 0.6, in spheres of 2 mm
    assert fill_particle_count(settings()) == 1758


@pytest.mark.parametrize(
    "given,message",
    [
        (
            {"seating_stress": 2.0e4},
            "s.seating_stress: 20000 Pa must be below max_stress (10000 Pa)",
        ),
        (
            {"modulus_band_lower": 0.05},
            "s.modulus_band_lower: the moduli's band would start at 500 Pa, below the seating "
            "stress (1000 Pa), where unloading ends; raise it to at least 0.1",
        ),
        (
            {"cylinder_diameter": 0.01},
            "s.cylinder_diameter: 0.01 m is less than 6 of the largest particles (0.002 m); "
            "use at least 0.012 m",
        ),
        (
            {"fill_height": 2.0},
            "s.fill_height: the fill needs 140625 spheres, more than 100000; use a smaller "
            "cylinder or a lower fill_height",
        ),
    ],
)
def test_settings_checks_name_the_field_and_the_allowed_range(given, message):
    with pytest.raises(ConfigError) as error:
        settings(**given)
    assert str(error.value) == message


# -- measures -------------------------------------------------------------------


def test_height_at_stress_interpolates_the_first_crossing():
    gap = np.array([10.0, 9.0, 8.0, 7.0, 6.0])
    stress = np.array([0.0, 100.0, 300.0, 200.0, 500.0])  # a dip after the first crossing
    assert measure.height_at_stress(gap, stress, 200.0) == pytest.approx(8.5)
    assert measure.height_at_stress(gap, stress, 0.0) == 10.0
    with pytest.raises(SimulationFailed, match="never reached 600 Pa"):
        measure.height_at_stress(gap, stress, 600.0)


def test_tangent_modulus_fits_the_band_only():
    strain = np.linspace(0.0, 0.02, 41)
    stress = np.where(strain < 0.01, 1.0e5 * strain, 1.0e3 + 4.0e5 * (strain - 0.01))
    assert measure.tangent_modulus(strain, stress, (1.0e3, 5.0e3)) == pytest.approx(4.0e5)
    with pytest.raises(SimulationFailed, match="only 0 samples .* slow the piston"):
        measure.tangent_modulus(strain, stress, (1.0e4, 2.0e4))


# -- analytic model -----------------------------------------------------------


def test_analytic_moduli_grow_as_the_two_thirds_power_of_stiffness():
    soft = SCENE.analytic_model(DEFAULTS, settings())
    stiff = SCENE.analytic_model({**DEFAULTS, "youngs_modulus": 8.0 * 5.0e6}, settings())
    for name in ("loading_modulus", "unloading_modulus"):
        assert stiff[name] / soft[name] == pytest.approx(4.0)
    assert soft["compressed_bulk_density"] > soft["seated_bulk_density"]
    assert stiff["compressed_bulk_density"] < soft["compressed_bulk_density"]


# -- tiny real LAMMPS runs ----------------------------------------------------


def tiny_job(tmp_path, fraction=0.25, responses=None, **params):
    return helpers.tiny_job("uniaxial_compression", tmp_path, responses, fraction, **params)


def plausible(job, responses):
    """Densities of a packing, denser under load; moduli positive, unloading the stiffer."""
    rho = job.parameters["particle_density"]
    seated, compressed = responses["seated_bulk_density"], responses["compressed_bulk_density"]
    return (
        0.35 * rho < seated <= compressed < 0.74 * rho
        and 0.0 < responses["loading_modulus"] < responses["unloading_modulus"]
    )


@pytest.mark.lammps
def test_tiny_compression_gives_plausible_responses_and_its_estimates(tmp_path):
    job = tiny_job(tmp_path)
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    assert plausible(job, responses), responses
    final = {row["response"] for row in read_partial(job.partial_file) if row["final"]}
    assert final == set(SCENE.responses)
    assert set(result.arrays["loading"]) == {0.0, 1.0}


@pytest.mark.lammps
@pytest.mark.slow
def test_a_stiffer_material_unloads_stiffer_as_hertz_contacts_do(tmp_path):
    """Effective-medium theory of Hertzian packings: moduli grow as E^(2/3), 4.6 times per
    decade of Young's modulus. Measured on the tiny scene: 4.75 from 5e7 to 5e8 Pa."""
    _, soft = run_lammps(tiny_job(tmp_path / "soft", youngs_modulus=5.0e7))
    _, stiff = run_lammps(tiny_job(tmp_path / "stiff", youngs_modulus=5.0e8))
    assert 3.0 < stiff["unloading_modulus"] / soft["unloading_modulus"] < 7.0


@pytest.mark.lammps
def test_oversized_time_step_fails_with_instability_reason(tmp_path):
    result, _ = run_lammps(tiny_job(tmp_path, fraction=1.5))
    assert result.status == Status.FAILED
    assert "unstable" in result.reason


@pytest.mark.lammps
@pytest.mark.parametrize("corner", PARAMETER_CORNERS)
@pytest.mark.slow
def test_extreme_corners_are_stable_and_plausible(tmp_path, corner):
    job = tiny_job(tmp_path, **PARAMETER_CORNERS[corner])
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    assert plausible(job, responses), responses


@pytest.mark.lammps
@pytest.mark.slow
def test_a_very_cohesive_material_is_compressed_and_measured(tmp_path):
    assert cohesive_corner_problem(tiny_job(tmp_path, **COHESIVE_CORNER), must_measure=True) is None


@pytest.mark.lammps
def test_stop_request_terminates_cleanly(tmp_path):
    job = tiny_job(tmp_path, youngs_modulus=5.0e8)
    result = run_lammps_stopped(job)
    assert (result.status, result.reason) == (Status.TERMINATED, "stop requested")
    assert result.arrays == {}
