"""Calibration device: its measures on hand-made data, geometry, settings, and tiny LAMMPS runs."""

import math

import numpy as np
import pytest
from helpers import COHESIVE_CORNER, PARAMETER_CORNERS, cohesive_corner_problem

from demcal.engines.base import RunMonitor, SimulationJob
from demcal.engines.lammps import LammpsEngine
from demcal.errors import ConfigError
from demcal.physics import measure
from demcal.physics.catalogue import CATALOG
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.calibration_device import TINY_SETTINGS, device_geometry

SCENE = SCENES.load("calibration_device")


# -- measures -------------------------------------------------------------------
def test_discharge_rate_fits_the_band_only():
    times = np.arange(11) * 0.1
    # 1 kg: a slow start (0.05 kg in 0.1 s), then 0.2 kg per 0.1 s, then a slow tail
    held = np.array([1.0, 0.95, 0.75, 0.55, 0.35, 0.15, 0.10, 0.06, 0.03, 0.01, 0.0])
    assert measure.discharge_rate(times, held, 1.0, (0.2, 0.8), 3.0) == pytest.approx(2.0)


def test_discharge_rate_of_a_stalled_flow_spreads_its_mass_over_the_time_allowed():
    times = np.array([0.0, 0.1, 0.2, 0.3])
    held = np.array([1.0, 0.9, 0.9, 0.9])  # clogged after 10 % left
    assert measure.discharge_rate(times, held, 1.0, (0.2, 0.8), 2.0) == pytest.approx(0.1 / 2.0)
    sooner = np.array([1.0, 0.95, 0.95, 0.95])
    assert measure.discharge_rate(times, sooner, 1.0, (0.2, 0.8), 2.0) < 0.1 / 2.0


def test_discharge_rate_sampled_too_coarsely_is_the_mean_rate():
    times = np.array([0.0, 0.1, 0.2])
    held = np.array([1.0, 0.5, 0.0])  # one sample in the band
    assert measure.discharge_rate(times, held, 1.0, (0.2, 0.8), 2.0) == pytest.approx(5.0)


def test_slide_time_is_the_first_time_below_the_threshold():
    times = np.array([0.0, 0.5, 1.0, 1.5])
    remaining = np.array([2.0, 1.0, 0.004, 0.0])
    assert measure.slide_time_with_penalty(times, remaining, 2.0, 0.003, 3.0) == 1.0


def test_slide_time_penalty_when_material_stays():
    """Thesis sec. 4.1: end time + 10 * remaining / total."""
    times = np.array([0.0, 0.5, 1.0])
    remaining = np.array([2.0, 0.6, 0.5])
    assert measure.slide_time_with_penalty(times, remaining, 2.0, 0.003, 3.0) == pytest.approx(
        3.0 + 10.0 * 0.25
    )


@pytest.mark.parametrize("angle", [10.0, 25.0, 40.0])
def test_sigmoid_fit_recovers_the_inflexion_angle(angle):
    width = 0.01
    high = 4.0 * width * math.tan(math.radians(angle))
    position = np.linspace(0.0, 0.2, 80)
    height = measure.falling_sigmoid(position, 0.001, 0.001 + high, 0.08, width)
    assert measure.heap_angle_sigmoid_fit(position, height) == pytest.approx(angle, abs=0.01)


def test_sigmoid_fit_needs_a_profile():
    with pytest.raises(Exception, match="only 2 columns"):
        measure.heap_angle_sigmoid_fit(np.array([0.0, 1.0]), np.array([1.0, 0.0]))


def test_surface_profile_along_x_takes_the_top_of_each_bin():
    x = np.array(
        [[0.001, 0.0, 0.001], [0.001, 0.005, 0.003], [0.0035, 0.0, 0.001], [0.009, 0.0, 0.001]]
    )
    r = np.full(4, 0.001)
    position, height = measure.surface_profile_along_x(x, r, 0.002, (0.0, 0.006))
    assert position == pytest.approx([0.001, 0.003])
    assert height == pytest.approx([0.004, 0.002])


# -- geometry and settings ------------------------------------------------------
def settings(**given):
    return SCENE.resolve_settings(given, "scenes.calibration_device.settings")


@pytest.mark.parametrize("wall_angle", [45.0, 60.0, 90.0])
def test_hopper_holds_the_insertion_volume(wall_angle):
    s = settings(hopper_wall_angle=wall_angle)
    d_max, volume, fraction = 2.0e-3, 6.0e-6, 0.25
    g = device_geometry(s, volume, d_max, fraction)
    h = g.fill_top - g.hopper_bottom - 0.6 * d_max
    width = s["orifice_width"] - 1.2 * d_max
    area = width * h + (
        0.0 if wall_angle == 90.0 else h * h / (2 * math.tan(math.radians(wall_angle)))
    )
    assert area * (s["depth"] - d_max) * fraction == pytest.approx(volume, rel=1e-6)
    # the outlet is above the slide, the slide's edge above the floor
    slide_below_outlet = g.slide_edge_height + math.tan(math.radians(s["slide_angle"])) * (
        g.outlet_left + s["orifice_width"] - g.slide_edge
    )
    assert g.hopper_bottom - g.wall_thickness == pytest.approx(
        slide_below_outlet + s["drop_height"]
    )
    assert g.box_right > g.outlet_left + s["orifice_width"]


@pytest.mark.parametrize(
    "given, message",
    [
        (
            {"orifice_width": 4.0e-3},
            "orifice_width: 0.004 m is less than 3 of the largest particles",
        ),
        (
            {"depth": 5.0e-3, "d50": 2.0e-3},
            "depth: 0.005 m is less than 3 of the largest particles",
        ),
        ({"slide_length": 5.0e-3}, "slide_length: 0.005 m puts the outlet past the slide's edge"),
        (
            {"slide_angle": 85.0},
            r"slide_angle: 85.0 is outside the allowed range: a number in \[5, 80\]",
        ),
        (
            {"slide_angle": 50.0, "hopper_wall_angle": 45.0},
            "slide_angle: 50 deg is not below hopper_wall_angle \\(45 deg\\)",
        ),
    ],
)
def test_bad_settings_name_field_and_range(given, message):
    with pytest.raises(ConfigError, match=message):
        settings(**given)


def test_analytic_model_trends():
    base = {name: spec.default for name, spec in CATALOG.items()}
    s = settings()
    low = SCENE.analytic_model({**base, "sliding_friction_pp": 0.2, "sliding_friction_pw": 0.2}, s)
    high = SCENE.analytic_model({**base, "sliding_friction_pp": 0.8, "sliding_friction_pw": 0.8}, s)
    assert high["mass_flow"] < low["mass_flow"]
    assert high["slide_time"] > low["slide_time"]
    assert high["angle_of_repose"] > low["angle_of_repose"]


# -- real LAMMPS on a tiny device ------------------------------------------------
def tiny_job(tmp_path, responses, fraction=0.25, **params):
    values = {name: spec.default for name, spec in CATALOG.items()}
    values.update({"youngs_modulus": 5.0e6, **params})
    return SimulationJob(
        scene="calibration_device",
        parameters=values,
        settings=settings(**TINY_SETTINGS),
        seed=3,
        responses=list(responses),
        timestep_fraction=fraction,
        workdir=str(tmp_path),
        stop_file=str(tmp_path / "STOP"),
    )


def run_lammps(job):
    return LammpsEngine().run(job, RunMonitor(job), SCENE.driver("lammps"))


@pytest.mark.lammps
@pytest.mark.slow
def test_tiny_device_gives_plausible_responses_and_an_early_estimate(tmp_path):
    job = tiny_job(tmp_path, ("mass_flow", "slide_time", "angle_of_repose"))
    result = run_lammps(job)
    assert result.status == Status.OK, result.reason
    aor = SCENE.extractors["angle_of_repose"](result.arrays, job.settings)
    total = 300 * job.parameters["particle_density"] * math.pi / 6 * 2.0e-3**3
    # a slot of 6 d discharges 2.3 g in well under a second, and not instantly
    assert 0.2 * total < result.measurements["mass_flow"] < 20.0 * total
    assert 0.0 < result.measurements["slide_time"] < job.settings["max_time"]
    assert 0.0 <= aor < 60.0
    estimates = [row for row in read_partial(job.partial_file) if row["response"]]
    assert estimates and estimates[0]["response"] == "mass_flow"
    assert estimates[0]["progress"] < 1.0


@pytest.mark.lammps
@pytest.mark.slow
def test_mass_flow_alone_ends_when_the_hopper_is_empty(tmp_path):
    full = tiny_job(tmp_path / "full", ("mass_flow", "slide_time", "angle_of_repose"))
    short = tiny_job(tmp_path / "short", ("mass_flow",))
    full_result = run_lammps(full)
    short_result = run_lammps(short)
    assert short_result.status == Status.OK and set(short_result.measurements) >= {"mass_flow"}
    assert "slide_time" not in short_result.measurements and "heap_x" not in short_result.arrays
    assert short_result.cost["steps"] < full_result.cost["steps"]
    # same seed, same discharge: the mass flow does not depend on what else is measured
    assert short_result.measurements["mass_flow"] == pytest.approx(
        full_result.measurements["mass_flow"], rel=1e-9
    )


@pytest.mark.lammps
def test_tiny_device_oversized_time_step_fails_with_a_reason(tmp_path):
    job = tiny_job(tmp_path, ("mass_flow",), fraction=1.5)
    result = run_lammps(job)
    assert result.status == Status.FAILED and "unstable" in result.reason


CORNERS = PARAMETER_CORNERS


@pytest.mark.lammps
@pytest.mark.parametrize("corner", CORNERS)
@pytest.mark.slow
def test_tiny_device_extreme_corners_are_stable(tmp_path, corner):
    """Corners of the parameter box: no blow-up, responses finite and in physical ranges.

    Full friction may stop the flow (a clogged slot or material left on the
    slide): that is a valid outcome, reported through the slide-time penalty.
    """
    job = tiny_job(tmp_path, ("mass_flow", "slide_time", "angle_of_repose"), **CORNERS[corner])
    result = run_lammps(job)
    assert result.status == Status.OK, result.reason
    assert result.measurements["mass_flow"] >= 0.0
    assert 0.0 < result.measurements["slide_time"] <= job.settings["max_time"] + 10.0
    assert 0.0 <= SCENE.extractors["angle_of_repose"](result.arrays, job.settings) < 90.0


@pytest.mark.lammps
@pytest.mark.slow
def test_a_very_cohesive_material_runs_or_fails_with_its_reason(tmp_path):
    assert (
        cohesive_corner_problem(
            tiny_job(tmp_path, ("mass_flow", "slide_time", "angle_of_repose"), **COHESIVE_CORNER)
        )
        is None
    )
