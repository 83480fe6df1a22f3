"""Rotating drum scene: declaration, regime checks, measures, analytic model, tiny LAMMPS runs.

The LAMMPS tests (marker ``lammps``) run a drum of about ten 3 mm spheres across, a slice
three deep (about 140 spheres), for a fifth of a revolution: a second or two per run.
"""

import math
from dataclasses import replace

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
from demcal.physics.psd import sample_diameters
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.rotating_drum import TINY_SETTINGS, drum_particle_count
from demcal.scenes.rotating_drum.regime import froude_number, rotation_speed_range

SCENE = SCENES.load("rotating_drum")
DEFAULTS = {name: spec.default for name, spec in CATALOG.items()}
RESPONSES = ("dynamic_angle_of_repose", "interface_fluctuation")


def settings(**given):
    return SCENE.resolve_settings(given, "s")


# -- declaration --------------------------------------------------------------


def test_defaults_fill_the_drum_in_the_rolling_regime():
    # 0.4 of pi 25^2 mm^2 x 10 mm at a solid fraction of 0.6, in spheres of 2 mm
    assert drum_particle_count(settings()) == 1125
    assert froude_number(settings()) == pytest.approx((15 * math.pi / 30) ** 2 * 0.025 / 9.81)
    low, high = rotation_speed_range(0.05)
    assert froude_number(settings(rotation_speed=low * 1.0001)) == pytest.approx(1.0e-4, rel=1e-3)
    assert froude_number(settings(rotation_speed=high * 0.9999)) == pytest.approx(1.0e-2, rel=1e-3)


@pytest.mark.parametrize(
    "given,message",
    [
        (
            {"rotation_speed": 60.0},
            "s.rotation_speed: 60 rpm gives a Froude number of 0.1, outside the rolling regime "
            "(0.0001 to 0.01, Mellmann 2001) where the dynamic angle is defined; for this drum "
            "use 1.89 to 18.9 rpm",
        ),
        (
            {"rotation_speed": 1.0},
            "s.rotation_speed: 1 rpm gives a Froude number of 2.8e-05, outside the rolling "
            "regime (0.0001 to 0.01, Mellmann 2001) where the dynamic angle is defined; for this "
            "drum use 1.89 to 18.9 rpm",
        ),
        (
            {"drum_diameter": 0.015},
            "s.drum_diameter: 0.015 m is less than 10 of the largest particles (0.002 m); use at "
            "least 0.02 m",
        ),
        (
            {"depth": 0.005},
            "s.depth: 0.005 m is less than 3 of the largest particles (0.002 m); use at least "
            "0.006 m",
        ),
        (
            {"depth": 1.0},
            "s.depth: the drum needs 112500 spheres, more than 100000; use a thinner periodic "
            "slice (depth), a smaller drum or a lower fill_level",
        ),
        (
            {"fill_level": 0.8},
            "s.fill_level: 0.8 is outside the allowed range: a number in [0.1, 0.6]",
        ),
    ],
)
def test_settings_checks_name_the_field_and_the_allowed_range(given, message):
    with pytest.raises(ConfigError) as error:
        settings(**given)
    assert str(error.value) == message


# -- analytic model -----------------------------------------------------------


@pytest.mark.parametrize("name", ["sliding_friction_pp", "rolling_friction_pp"])
def test_analytic_dynamic_angle_rises_with_friction(name):
    angles = [
        SCENE.analytic_model({**DEFAULTS, name: v}, settings())["dynamic_angle_of_repose"]
        for v in np.linspace(0.0, 1.0, 11)
    ]
    assert np.all(np.diff(angles) > 0.0)
    assert 10.0 < angles[0] and angles[-1] < 60.0


def test_analytic_dynamic_angle_rises_with_speed_across_the_rolling_regime():
    angles = [
        SCENE.analytic_model(DEFAULTS, settings(rotation_speed=v))["dynamic_angle_of_repose"]
        for v in np.linspace(2.0, 18.0, 9)
    ]
    assert np.all(np.diff(angles) > 0.0)


def test_analytic_adhesion_raises_the_angle_and_the_fluctuation_most():
    found = [
        SCENE.analytic_model({**DEFAULTS, "surface_energy_pp": v}, settings())
        for v in (0.0, 0.02, 0.1, 0.5)
    ]
    for name in RESPONSES:
        assert np.all(np.diff([f[name] for f in found]) > 0.0)
    assert found[-1]["interface_fluctuation"] > 2.0 * found[0]["interface_fluctuation"]
    lift = SCENES.load("cylinder_lift")
    lift_settings = lift.resolve_settings({}, "s")
    angles = [
        lift.analytic_model({**DEFAULTS, "surface_energy_pp": v}, lift_settings)["angle_of_repose"]
        for v in (0.0, 0.02, 0.1, 0.5)
    ]
    assert np.all(np.diff(angles) > 0.0)


def test_analytic_engine_runs_the_scene_with_early_estimates(tmp_path):
    job = SimulationJob(
        scene="rotating_drum",
        parameters=DEFAULTS,
        settings=settings(),
        seed=3,
        responses=list(RESPONSES),
        timestep_fraction=0.25,
        workdir=str(tmp_path),
        stop_file=str(tmp_path / "STOP"),
    )
    result = AnalyticEngine({"noise": 0.0, "chunks": 4}).run(
        job, RunMonitor(job), SCENE.driver("analytic")
    )
    assert result.status == Status.OK
    assert result.measurements == pytest.approx(SCENE.analytic_model(DEFAULTS, job.settings))
    assert {r["response"] for r in read_partial(job.partial_file)} >= set(RESPONSES)


# -- measures -------------------------------------------------------------------


def tilted_bed(angle, radius=0.02, cell=1.0e-3, lift=0.0):
    """Spheres of radius cell/2 filling a drum of ``radius`` below a plane through its axis
    tilted by ``angle`` [deg] and raised by ``lift`` [m]: one snapshot, (N x 2) and (N)."""
    grid = np.arange(-radius, radius, cell / 2.0) + cell / 4.0
    x, z = (v.ravel() for v in np.meshgrid(grid, grid))
    below = (np.hypot(x, z) < radius) & (z < lift - math.tan(math.radians(angle)) * x)
    return np.column_stack([x[below], z[below]]), np.full(below.sum(), cell / 2.0)


@pytest.mark.parametrize("angle", [15.0, 30.0, 40.0])
def test_drum_interface_recovers_the_angle_of_a_plane_surface(angle):
    xz, r = tilted_bed(angle)
    centres, heights = measure.drum_surface_heights(xz[None], r[None], 0.02, 1.0e-3)
    found, fluctuation = measure.drum_interface(centres, heights, 0.6)
    assert found == pytest.approx(angle, abs=1.0)
    assert fluctuation == 0.0


def test_drum_interface_fluctuation_is_the_rms_deviation_from_the_average_surface():
    lift = 2.0e-3
    snapshots = [tilted_bed(30.0, lift=v) for v in (-lift, lift)]
    centres, heights = measure.drum_surface_heights(
        [xz for xz, _ in snapshots], [r for _, r in snapshots], 0.02, 1.0e-3
    )
    angle, fluctuation = measure.drum_interface(centres, heights, 0.5)
    assert angle == pytest.approx(30.0, abs=1.0)
    assert fluctuation == pytest.approx(lift, rel=0.15)


def test_drum_interface_refuses_too_few_columns_and_an_empty_drum():
    xz, r = tilted_bed(30.0, radius=0.002)
    centres, heights = measure.drum_surface_heights(xz[None], r[None], 0.002, 1.0e-3)
    with pytest.raises(SimulationFailed, match="spans only 2 columns in its central band"):
        measure.drum_interface(centres, heights, 0.6)
    with pytest.raises(SimulationFailed, match="holds no material"):
        measure.drum_interface(centres, np.full_like(heights, np.nan), 0.6)


def test_spheres_are_placed_in_the_drum_without_overlap_across_the_periodic_faces():
    rng = np.random.default_rng(5)
    diameters = sample_diameters(300, 2.0e-3, 0.2, 2.0, rng)
    radius, depth = 0.015, 0.008
    centres = random_loose_packing(
        diameters,
        (-radius, 0.0, -radius),
        (radius, depth, radius),
        rng,
        "the drum",
        inside=lambda c, a: math.hypot(c[0], c[2]) <= radius - a,
        periodic=(False, True, False),
    )
    radii = diameters / 2
    assert np.all(np.hypot(centres[:, 0], centres[:, 2]) <= radius - radii)
    assert np.all((centres[:, 1] >= 0.0) & (centres[:, 1] < depth))
    apart = centres[:, None] - centres[None]
    apart[..., 1] -= depth * np.round(apart[..., 1] / depth)
    gap = np.linalg.norm(apart, axis=2) - (radii[:, None] + radii[None])
    np.fill_diagonal(gap, np.inf)
    assert gap.min() >= 0.0
    # spheres do cross the periodic faces (else the test would prove nothing about them)
    assert np.any((centres[:, 1] < radii) | (centres[:, 1] > depth - radii))


# -- tiny real LAMMPS runs ----------------------------------------------------


def tiny_job(tmp_path, fraction=0.25, responses=None, **params):
    return helpers.tiny_job("rotating_drum", tmp_path, responses, fraction, **params)


def plausible(job, responses):
    """A flowing surface: an angle below 60 deg, a fluctuation below a particle diameter."""
    return (
        0.0 <= responses["dynamic_angle_of_repose"] < 60.0
        and 0.0 < responses["interface_fluctuation"] < job.settings["d50"]
    )


@pytest.mark.lammps
def test_tiny_drum_gives_plausible_responses_and_early_estimates(tmp_path):
    job = tiny_job(tmp_path)
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    assert 20.0 < responses["dynamic_angle_of_repose"] < 45.0
    assert plausible(job, responses), responses
    rows = read_partial(job.partial_file)
    angles = [row for row in rows if row["response"] == "dynamic_angle_of_repose"]
    assert len(angles) == TINY_SETTINGS["snapshots"] and angles[-1]["final"]
    assert result.arrays["surface_xz"].shape[:2] == (
        TINY_SETTINGS["snapshots"],
        drum_particle_count(job.settings),
    )
    times, values = SCENE.history(result.arrays, job.settings)["dynamic_angle_of_repose"]
    assert len(times) == len(values) == TINY_SETTINGS["snapshots"]


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
def test_the_fastest_rolling_drum_is_stable_and_plausible(tmp_path):
    """The top of the rolling regime (Fr = 0.01), with stiff particles: the fastest walls and
    the shortest time step the scene allows."""
    _, fastest = rotation_speed_range(TINY_SETTINGS["drum_diameter"])
    job = tiny_job(tmp_path, youngs_modulus=5.0e8)
    job = replace(job, settings=settings(**{**TINY_SETTINGS, "rotation_speed": 0.999 * fastest}))
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
def test_a_very_cohesive_material_turns_in_lumps_and_is_measured(tmp_path):
    assert cohesive_corner_problem(tiny_job(tmp_path, **COHESIVE_CORNER), must_measure=True) is None
