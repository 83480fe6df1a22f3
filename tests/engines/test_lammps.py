"""The real LAMMPS engine on a tiny cylinder lift (200 spheres of 3 mm, seconds per run).

Stiff and extreme corners of the parameter box must give stable, physically
plausible responses; an oversized time step must end as a failure with an
instability reason, never as a hang or a crash.
"""

import math
import time

import helpers
import pytest
from helpers import (
    COHESIVE_CORNER,
    PARAMETER_CORNERS,
    cohesive_corner_problem,
    run_and_extract,
    run_lammps,
    run_lammps_stopped,
)

from demcal.engines.lammps import LammpsEngine
from demcal.results.records import Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.cylinder_lift import TINY_SETTINGS

pytestmark = pytest.mark.lammps

SCENE = SCENES.load("cylinder_lift")
#: Solid fraction bounds of the fill. Dense random packing is 0.64; the loose
#: bound is below bulk random loose packing (0.55) because in a cylinder only
#: 8 diameters wide the wall zone and the top layer are loosely packed.
LOOSE, DENSE = 0.42, 0.66


def tiny_job(tmp_path, fraction=0.25, responses=("bulk_density", "angle_of_repose"), **params):
    return helpers.tiny_job("cylinder_lift", tmp_path, responses, fraction, **params)


CORNERS = {
    **PARAMETER_CORNERS,
    "stiff_6.5e8_Pa": dict(youngs_modulus=6.5e8),
}  # top of Rackl & Hanley's range


@pytest.mark.parametrize("corner", CORNERS)
@pytest.mark.slow
def test_extreme_corners_are_stable_and_plausible(tmp_path, corner):
    job = tiny_job(tmp_path, **CORNERS[corner])
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    solid_fraction = responses["bulk_density"] / job.parameters["particle_density"]
    assert LOOSE < solid_fraction < DENSE
    assert 0.0 <= responses["angle_of_repose"] < 90.0
    assert math.isfinite(result.cost["steps"]) and result.cost["steps"] > 0


@pytest.mark.slow
def test_friction_raises_the_heap(tmp_path):
    _, smooth = run_lammps(tiny_job(tmp_path / "a", **CORNERS["frictionless"]))
    _, rough = run_lammps(
        tiny_job(tmp_path / "b", sliding_friction_pp=0.8, rolling_friction_pp=0.3)
    )
    assert rough["angle_of_repose"] > smooth["angle_of_repose"] + 5.0


def test_oversized_time_step_fails_with_instability_reason(tmp_path):
    result, _ = run_lammps(tiny_job(tmp_path, fraction=1.5))
    assert result.status == Status.FAILED
    assert "unstable" in result.reason


def test_bulk_density_alone_skips_the_lift(tmp_path):
    job = tiny_job(tmp_path, responses=("bulk_density",))
    result, responses = run_lammps(job)
    stages = {row["stage"] for row in read_partial(job.partial_file)}
    assert result.status == Status.OK and "bulk_density" in responses
    assert stages == {"fill"} and "heap_x" not in result.arrays


def test_a_trimmed_fill_ends_at_the_trim_height_and_loses_nothing_else(tmp_path):
    """Rackl & Hanley (2017, sec. 2.2): poured above 50 mm, trimmed to it, settled again."""
    job = tiny_job(tmp_path)
    whole, _ = run_lammps(tiny_job(tmp_path / "whole", responses=("bulk_density",)))
    trim = 0.7 * whole.measurements["fill_height"]
    job.settings = {**job.settings, "trim_height": trim}
    result, responses = run_lammps(job)
    assert result.status == Status.OK, result.reason
    stages = {row["stage"] for row in read_partial(job.partial_file)}
    assert {"fill", "trimmed fill", "lift", "heap"} <= stages
    assert result.measurements["fill_height"] <= trim + 0.5 * TINY_SETTINGS["d50"]
    assert len(result.arrays["fill_x"]) < TINY_SETTINGS["particle_count"]
    assert result.measurements["lost_particles"] >= 0
    assert LOOSE < responses["bulk_density"] / job.parameters["particle_density"] < DENSE
    too_high = tiny_job(tmp_path / "high", responses=("bulk_density",))
    too_high.settings = {
        **too_high.settings,
        "trim_height": 2.0 * whole.measurements["fill_height"],
    }
    failed, _ = run_lammps(too_high)
    assert failed.status == Status.FAILED and "raise particle_count" in failed.reason


def test_dumps_only_when_asked(tmp_path):
    quiet = tiny_job(tmp_path / "quiet", responses=("bulk_density",))
    run_lammps(quiet)
    asked = tiny_job(tmp_path / "asked", responses=("bulk_density",))
    asked.settings = {**asked.settings, "dump_interval": 0.05}
    run_lammps(asked)
    assert not (tmp_path / "quiet" / "dump.lammpstrj").exists()
    assert (tmp_path / "asked" / "dump.lammpstrj").read_text().count("ITEM: TIMESTEP") >= 3


def test_stop_request_terminates_cleanly(tmp_path):
    job = tiny_job(tmp_path, youngs_modulus=5.0e8)
    result = run_lammps_stopped(job)
    assert (result.status, result.reason) == (Status.TERMINATED, "stop requested")
    assert result.arrays == {}


def test_a_run_beyond_the_wall_clock_limit_is_killed_and_recorded_as_failed(tmp_path):
    """The stiff tiny run takes about 5 s; with a 1 s limit it is killed, not waited for."""
    job = tiny_job(tmp_path, youngs_modulus=6.5e8)
    start = time.monotonic()
    result, _ = run_and_extract(LammpsEngine({"timeout": 1}), job)
    assert result.status == Status.FAILED
    assert result.reason.startswith(
        "LAMMPS run exceeded the engine timeout of 1 s (engine.timeout)"
    )
    assert time.monotonic() - start < 4.0


@pytest.mark.lammps
@pytest.mark.slow
def test_a_very_cohesive_material_runs_or_fails_with_its_reason(tmp_path):
    assert cohesive_corner_problem(tiny_job(tmp_path, **COHESIVE_CORNER)) is None
