"""Shear box scene (Richter & Will 2021): declaration, measures, analytic model, tiny LAMMPS runs.

The LAMMPS tests (marker ``lammps``) run a box of 5 largest particles
(about 230 spheres of 3 mm, a second or two per run at E = 5e6 Pa).
"""

import math

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

from demcal.engines.analytic import AnalyticEngine
from demcal.engines.base import RunMonitor, SimulationJob
from demcal.engines.particles import random_loose_packing
from demcal.errors import ConfigError, SimulationFailed
from demcal.physics import measure
from demcal.physics.catalogue import CATALOG
from demcal.physics.psd import mean_sphere_volume, sample_diameters
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.shear_box import (
    box_dimensions,
    fill_particle_count,
)

SCENE = SCENES.load("shear_box")
DEFAULTS = {name: spec.default for name, spec in CATALOG.items()}


def settings(**given):
    return SCENE.resolve_settings(given, "s")


# -- declaration --------------------------------------------------------------


def test_box_is_scaled_to_ten_largest_particles_by_default():
    # gravel 8/16: d_max = 11.16 mm exp(1.5 * 0.26) = 16.483 mm; base 100 x 100 x 150 mm
    length, width, height = box_dimensions(settings())
    assert (length, width, height) == pytest.approx((0.16483, 0.16483, 0.24725), abs=2e-5)


def test_particle_count_fills_the_box_at_dense_packing():
    # monodisperse: box 10 d x 10 d x 15 d = 1500 d^3; 0.70 * 1500 / (pi / 6) = 2005.4
    assert fill_particle_count(settings(sigma_ln=0.0)) == 2006


def test_mean_sphere_volume_of_the_truncated_lognormal():
    d50 = 2.0e-3
    assert mean_sphere_volume(d50, 0.0, 2.0) == pytest.approx(math.pi / 6 * d50**3)
    # no truncation to speak of: E[d^3] = d50^3 exp(4.5 sigma^2)
    assert mean_sphere_volume(d50, 0.3, 30.0) == pytest.approx(
        math.pi / 6 * d50**3 * math.exp(4.5 * 0.09)
    )
    sample = sample_diameters(200_000, d50, 0.4, 1.5, np.random.default_rng(1))
    assert mean_sphere_volume(d50, 0.4, 1.5) == pytest.approx(
        float(np.mean(math.pi / 6 * sample**3)), rel=0.01
    )


@pytest.mark.parametrize(
    "given,message",
    [
        (
            {"angle_band_lower": 0.8, "angle_band_upper": 0.5},
            "s.angle_band_lower: 0.8 must be below angle_band_upper (0.5)",
        ),
        (
            {"box_size_dmax": 4.0, "sigma_ln": 0.0, "d50": 3.0e-3},
            "s.box_size_dmax: the box is only 4 median diameters long (0.012 m); the slope fit "
            "needs at least 5: raise box_size_dmax",
        ),
        (
            {"sigma_ln": 1.2, "psd_truncation": 4.0},
            "s.sigma_ln: the box (smallest side 10 largest particles) needs 8418886 spheres of "
            "this PSD, more than 100000; narrow the PSD (sigma_ln, psd_truncation) or lower "
            "box_size_dmax",
        ),
        (
            {"box_size_dmax": 2.0},
            "s.box_size_dmax: 2.0 is outside the allowed range: a number in [4, 40] d_max",
        ),
    ],
)
def test_settings_checks_name_the_field_and_the_allowed_range(given, message):
    with pytest.raises(ConfigError) as error:
        settings(**given)
    assert str(error.value) == message


# -- analytic model -----------------------------------------------------------


@pytest.mark.parametrize(
    "name",
    ["sliding_friction_pp", "rolling_friction_pp", "sliding_friction_pw", "rolling_friction_pw"],
)
def test_analytic_shear_angle_rises_with_friction(name):
    angles = [
        SCENE.analytic_model({**DEFAULTS, name: v}, settings())["shear_angle"]
        for v in np.linspace(0.0, 1.0, 11)
    ]
    assert np.all(np.diff(angles) > 0.0)
    assert 5.0 < angles[0] and angles[-1] < 60.0


@pytest.mark.parametrize("name", ["sliding_friction_pp", "rolling_friction_pp"])
def test_analytic_packing_loosens_with_friction(name):
    density = [
        SCENE.analytic_model({**DEFAULTS, name: v}, settings())["bulk_density"]
        for v in np.linspace(0.0, 1.0, 11)
    ]
    assert np.all(np.diff(density) < 0.0)


def test_analytic_angle_ignores_size_stiffness_and_density():
    base = SCENE.analytic_model(DEFAULTS, settings())
    other = SCENE.analytic_model(
        {**DEFAULTS, "youngs_modulus": 5e8, "particle_density": 1000.0}, settings(d50=2.0e-3)
    )
    assert other["shear_angle"] == base["shear_angle"]
    assert other["bulk_density"] == pytest.approx(base["bulk_density"] * 1000.0 / 2500.0)


def test_analytic_engine_runs_the_scene_with_early_estimates(tmp_path):
    job = SimulationJob(
        scene="shear_box",
        parameters=DEFAULTS,
        settings=settings(),
        seed=3,
        responses=["bulk_density", "shear_angle"],
        timestep_fraction=0.25,
        workdir=str(tmp_path),
        stop_file=str(tmp_path / "STOP"),
    )
    result = AnalyticEngine({"noise": 0.0, "chunks": 4}).run(
        job, RunMonitor(job), SCENE.driver("analytic")
    )
    assert result.status == Status.OK
    assert result.measurements == pytest.approx(SCENE.analytic_model(DEFAULTS, job.settings))
    assert {r["response"] for r in read_partial(job.partial_file)} >= {
        "bulk_density",
        "shear_angle",
    }


# -- measures -------------------------------------------------------------------


def test_column_tops_takes_the_highest_point_per_column():
    x = np.array([[0.5, 0.5, 1.0], [0.6, 0.4, 3.0], [1.5, 0.5, 2.0]])
    centres, top = measure.column_tops(x, np.array([0.5, 0.25, 0.5]), 1.0)
    assert centres.tolist() == [[0.5, 0.5], [1.5, 0.5]]
    assert top.tolist() == [3.25, 2.5]


def test_box_bulk_density_counts_sphere_centres_inside_the_box():
    x = np.array([[0.1, 0.1, 0.1], [0.5, 0.9, 0.95], [0.9, 0.5, 0.5], [0.5, 0.5, 1.01]])
    mass = np.array([1.0, 2.0, 3.0, 4.0])
    # box 1 x 1 x 1 m: the fourth centre is above the top
    assert measure.box_bulk_density(x, mass, (1.0, 1.0, 1.0)) == 6.0
    # box 2 x 0.5 x 1 m (1 m^3): the second centre is beyond the width
    assert measure.box_bulk_density(x, mass, (2.0, 0.5, 1.0)) == 4.0


def stacked_slope(angle_deg, length=0.04, width=0.01, d=1.0e-3, cap=None):
    """Columns of spheres whose tops follow z = (length - x) tan(angle), capped at ``cap``."""
    slope = math.tan(math.radians(angle_deg))
    centres = []
    for i in range(int(length / d)):
        for j in range(int(width / d)):
            x = (i + 0.5) * d
            height = (length - x) * slope if cap is None else min(cap, (length - x) * slope)
            centres += [(x, (j + 0.5) * d, (k + 0.5) * d) for k in range(max(1, round(height / d)))]
    x = np.array(centres)
    return x, np.full(len(x), d / 2)


@pytest.mark.parametrize("angle", [15.0, 30.0, 40.0])
def test_box_slope_angle_of_a_plane_slope(angle):
    x, r = stacked_slope(angle)
    assert measure.box_slope_angle(x, r, 1.0e-3, 0.04) == pytest.approx(angle, abs=1.0)


def test_box_slope_angle_leaves_out_the_plateau_and_spheres_past_the_lip():
    x, r = stacked_slope(35.0, cap=0.015)  # struck-off plateau at the back wall
    falling = np.array([[0.045, 0.005, -0.002]])  # a sphere past the opening
    x, r = np.vstack([x, falling]), np.append(r, 5e-4)
    assert measure.box_slope_angle(x, r, 1.0e-3, 0.04) == pytest.approx(35.0, abs=1.5)


def test_box_slope_angle_rising_surface_is_zero_and_empty_box_fails():
    x, r = stacked_slope(30.0)
    x[:, 0] = 0.04 - x[:, 0]  # mirrored: rises towards the opening
    assert measure.box_slope_angle(x, r, 1.0e-3, 0.04) == 0.0
    with pytest.raises(SimulationFailed, match="no particles left in the box"):
        measure.box_slope_angle(x + [1.0, 0.0, 0.0], r, 1.0e-3, 0.04)


def test_random_loose_packing_places_spheres_without_overlap():
    rng = np.random.default_rng(5)
    diameters = sample_diameters(400, 2.0e-3, 0.3, 2.0, rng)
    lower, upper = np.zeros(3), np.array([0.02, 0.02, 0.05])
    centres = random_loose_packing(diameters, lower, upper, rng, "the block")
    radii = diameters / 2
    assert np.all(centres - radii[:, None] >= lower) and np.all(centres + radii[:, None] <= upper)
    gap = np.linalg.norm(centres[:, None] - centres[None], axis=2) - (radii[:, None] + radii[None])
    np.fill_diagonal(gap, np.inf)
    assert gap.min() >= 0.0
    with pytest.raises(SimulationFailed, match="could place only .* in the block"):
        random_loose_packing(
            diameters, lower, np.array([0.02, 0.02, 0.005]), rng, "the block", max_tries=50
        )


# -- tiny real LAMMPS runs ----------------------------------------------------


def tiny_job(tmp_path, fraction=0.25, responses=("bulk_density", "shear_angle"), **params):
    return helpers.tiny_job("shear_box", tmp_path, responses, fraction, **params)


#: Solid fraction bounds for any material. Dense random packing is 0.64; the
#: loose bound is below random loose packing (0.55) because with mu = mu_r = 1
#: the tiny box packs at 0.44 (its wall zone is a large share of it).
LOOSE, DENSE = 0.40, 0.66


def plausible(job, responses):
    solid_fraction = responses["bulk_density"] / job.parameters["particle_density"]
    return LOOSE < solid_fraction < DENSE and 0.0 <= responses.get("shear_angle", 0.0) < 60.0


@pytest.mark.lammps
def test_tiny_box_gives_plausible_responses_and_early_estimates(tmp_path):
    job = tiny_job(tmp_path, sliding_friction_pp=0.5)
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    assert 0.45 < responses["bulk_density"] / job.parameters["particle_density"] < 0.7
    assert 10.0 < responses["shear_angle"] < 45.0
    estimates = {(row["stage"], row["response"]) for row in read_partial(job.partial_file)}
    assert {("fill", "bulk_density"), ("outflow", "shear_angle")} <= estimates
    assert result.measurements["particles_left"] < result.measurements["fill_particles"]


@pytest.mark.lammps
def test_bulk_density_alone_ends_after_the_fill(tmp_path):
    job = tiny_job(tmp_path, responses=("bulk_density",))
    result, responses = run_lammps(job)
    stages = {row["stage"] for row in read_partial(job.partial_file)}
    assert result.status == Status.OK and plausible(job, responses)
    assert stages == {"fill"} and "slope_x" not in result.arrays


@pytest.mark.lammps
def test_oversized_time_step_fails_with_instability_reason(tmp_path):
    result, _ = run_lammps(tiny_job(tmp_path, fraction=1.5))
    assert result.status == Status.FAILED
    assert "unstable" in result.reason


CORNERS = PARAMETER_CORNERS


@pytest.mark.lammps
@pytest.mark.parametrize("corner", CORNERS)
@pytest.mark.slow
def test_extreme_corners_are_stable_and_plausible(tmp_path, corner):
    job = tiny_job(tmp_path, **CORNERS[corner])
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    assert plausible(job, responses), responses


@pytest.mark.lammps
def test_stop_request_terminates_cleanly(tmp_path):
    job = tiny_job(tmp_path, youngs_modulus=5.0e8)
    result = run_lammps_stopped(job)
    assert (result.status, result.reason) == (Status.TERMINATED, "stop requested")
    assert result.arrays == {}


@pytest.mark.lammps
@pytest.mark.slow
def test_a_very_cohesive_material_runs_or_fails_with_its_reason(tmp_path):
    assert cohesive_corner_problem(tiny_job(tmp_path, **COHESIVE_CORNER)) is None
