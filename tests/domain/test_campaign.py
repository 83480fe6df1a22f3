"""Sampling campaigns (issue 22, item 1): space-filling designs, their measures, extension,
and ``demcal sample`` on the analytic engine; its size bound, its forecast and its Snakemake
ending with it (issue 35, item 5)."""

from __future__ import annotations

import contextlib
import copy
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import ANALYTIC_STUDY, demcal, finish

from demcal.archive.simulation import ArchivedSimulation
from demcal.archive.store import Archive
from demcal.daemon.launcher import alive
from demcal.domain.campaign import (
    check_request,
    end_earlier_runs,
    forecast,
    plan,
    tally,
    write_points,
)
from demcal.engines.base import descendants
from demcal.errors import ConfigError
from demcal.optimizer.designs import (
    cover_measure,
    extend_design,
    fssf_f,
    latin_hypercube,
    minimum_pairwise_distance,
    sobol_sequence,
)
from demcal.results.records import CampaignRecord, PointRecord, ResponsesRecord, Status
from demcal.study.config import load_study
from demcal.study.model import freeze


def test_the_cover_measure_is_zero_on_a_grid_and_grows_with_unevenness():
    grid = np.array([[x, y] for x in (0.25, 0.75) for y in (0.25, 0.75)])
    assert cover_measure(grid) == pytest.approx(0.0, abs=1e-12)
    # nearest-neighbour distances 0.1, 0.1, 0.5 (for the lone point): sd / mean
    uneven = np.array([[0.0, 0.0], [0.1, 0.0], [0.6, 0.0]])
    gaps = np.array([0.1, 0.1, 0.5])
    assert cover_measure(uneven) == pytest.approx(gaps.std() / gaps.mean())


@pytest.mark.parametrize("dimension", [2, 7, 10])
def test_fssf_f_fills_space_better_than_latin_hypercubes(dimension):
    """Richter & Will (2021, Figs. 7-8): FSSF-f has the larger minimum inter-site distance
    and the smaller cover measure; here against the mean of ten random Latin hypercubes."""
    size = 60
    design = fssf_f(size, dimension, np.random.default_rng(1))
    assert design.shape == (size, dimension) and ((0 <= design) & (design <= 1)).all()
    rng = np.random.default_rng(2)
    hypercubes = [latin_hypercube(size, dimension, rng) for _ in range(10)]
    assert minimum_pairwise_distance(design) > np.mean(
        [minimum_pairwise_distance(h) for h in hypercubes]
    )
    assert cover_measure(design) < np.mean([cover_measure(h) for h in hypercubes])


def test_fssf_f_starts_at_the_centre():
    design = fssf_f(5, 3, np.random.default_rng(4))
    assert np.linalg.norm(design[0] - 0.5) < 0.05
    assert minimum_pairwise_distance(design) > 0.4


def test_an_extension_keeps_the_points_and_the_space_filling():
    dimension = 4
    first = fssf_f(20, dimension, np.random.default_rng(5))
    more = extend_design("fssf_f", first, 40, dimension, np.random.default_rng(5))
    whole = np.vstack([first, more])
    fresh = fssf_f(40, dimension, np.random.default_rng(5))
    assert len(more) == 20
    assert minimum_pairwise_distance(whole) >= 0.8 * minimum_pairwise_distance(fresh)
    sobol = sobol_sequence(16, dimension, np.random.default_rng(5))
    tail = extend_design("sobol", sobol[:8], 16, dimension, np.random.default_rng(5))
    np.testing.assert_array_equal(tail, sobol[8:])
    with pytest.raises(ValueError, match="cannot be extended"):
        extend_design("latin_hypercube", first, 40, dimension, np.random.default_rng(5))


def test_a_campaign_grows_by_its_next_points_and_refuses_another_design(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(copy.deepcopy(ANALYTIC_STUDY)))
    first = plan(study, 6, "fssf_f")
    first.write(study.files.campaign)
    grown = plan(study, 10, "fssf_f")
    assert grown.unit_points[:6] == first.unit_points and len(grown.unit_points) == 10
    assert plan(study, 4, "fssf_f") == first  # a smaller --points changes nothing
    with pytest.raises(ConfigError, match="--design sobol: the campaign .* is a fssf_f design"):
        plan(study, 10, "sobol")
    CampaignRecord("latin_hypercube", 1, first.unit_points).write(study.files.campaign)
    with pytest.raises(ConfigError, match="cannot be extended and stay space-filling"):
        plan(study, 10, "latin_hypercube")
    with pytest.raises(ConfigError, match="--points 1: give 2 to 2500 points .* here 2 per point"):
        plan(study, 1, "sobol")
    with pytest.raises(ConfigError, match="--points 2501: give 2 to 2500 points"):
        plan(study, 2501, "sobol")  # 2 replicates: 5002 simulations
    with pytest.raises(ConfigError, match="--bundle 0: give at least 1 simulation per"):
        check_request(4, "fssf_f", bundle=0)
    renamed = freeze(load_study({**copy.deepcopy(ANALYTIC_STUDY), "study": "held-out"}))
    assert plan(renamed, 6, "fssf_f").unit_points != first.unit_points  # a design of its own


def test_a_calibration_folder_is_not_taken_for_a_campaign(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(copy.deepcopy(ANALYTIC_STUDY)))
    PointRecord({"sliding_friction_pp": 0.5, "rolling_friction_pp": 0.1}).write(
        study.files.evaluation("e0000").params
    )
    with pytest.raises(ConfigError, match="holds evaluations that are not a campaign's"):
        plan(study, 6, "fssf_f")


def test_a_failed_point_is_retried_with_its_next_attempt(tmp_path, monkeypatch):
    """A rerun of the campaign runs a failed simulation again under a new seed (the archive
    keeps both runs); ok ones stay."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study({**copy.deepcopy(ANALYTIC_STUDY), "replicates": 1}))
    campaign = plan(study, 2, "sobol")
    names = write_points(study, campaign)
    failed = study.files.evaluation(names[0]).replicate("cylinder_lift", 0)
    ok = study.files.evaluation(names[1]).replicate("cylinder_lift", 0)
    ResponsesRecord(Status.FAILED, "node lost").write(failed.responses)
    ResponsesRecord(Status.OK, responses={"angle_of_repose": 20.0}).write(ok.responses)
    assert tally(study, names).statuses == {"failed": 1, "ok": 1}
    write_points(study, campaign)
    point = PointRecord.read(study.files.evaluation(names[0]).params)
    assert point.attempt == 1 and point.previous_failures == ["node lost"]
    assert not failed.responses.exists() and ok.responses.exists()
    before = tally(study, names)
    assert not before.hopeless()


@pytest.mark.slow
def test_demcal_sample_runs_the_design_into_the_archive_and_stops_when_all_fail(tmp_path):
    config = {**copy.deepcopy(ANALYTIC_STUDY), "study": "campaign", "replicates": 1}
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump(config))
    out = finish(demcal(tmp_path, "sample", "campaign.yaml", "--points", "4"))
    assert "fssf_f design of 4 points at fine in 2 parameters" in out
    assert "4 of 4 simulations finished (4 ok)" in out
    assert len(finish(demcal(tmp_path, "archive", "list", "--study", "campaign")).splitlines()) == 4
    failing = {
        **config,
        "study": "failing",
        "engine": {
            "name": "analytic",
            "failures": [{"when": {"sliding_friction_pp": [0.0, 1.0]}, "reason": "mesh broke"}],
        },
    }
    (tmp_path / "failing.yaml").write_text(yaml.safe_dump(failing))
    stopped = demcal(tmp_path, "sample", "failing.yaml", "--points", "40")
    _, err = stopped.communicate(timeout=240)
    assert stopped.returncode == 1
    assert "the first 5 simulations all failed (commonest: mesh broke)" in err


def test_the_forecast_prices_the_simulations_left_at_the_archives_median(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study({**copy.deepcopy(ANALYTIC_STUDY), "replicates": 1}))
    campaign = plan(study, 4, "sobol")
    names = write_points(study, campaign)
    unknown = forecast(study, campaign, {"cores": 2})
    assert unknown == (
        "4 of 4 simulations to run, 2 at a time; how long they take is not known yet: the "
        "archive holds no finished cylinder_lift simulation on analytic"
    )
    with Archive(study.archive) as archive:
        archive.add(
            ArchivedSimulation(
                study="earlier",
                evaluation=f"e{n:04d}",
                scene="cylinder_lift",
                replicate=0,
                engine="analytic",
                engine_version="analytic-1",
                settings={},
                timestep_fraction=0.25,
                status=Status.OK,
                cost={"wall_s": wall},
            )
            for n, wall in enumerate([10.0, 30.0, 500.0])
        )
    finished = study.files.evaluation(names[0]).replicate("cylinder_lift", 0).responses
    ResponsesRecord(Status.OK, responses={"angle_of_repose": 20.0}).write(finished)
    assert forecast(study, campaign, {"executor": "slurm", "jobs": 3}) == (
        "3 of 4 simulations to run, 3 at a time: about 30 s, at the median wall time of the "
        "archive's simulations on analytic: cylinder_lift 30 s (3 runs)"
    )


def snakemake_on(argument: str) -> int:
    """A stand-in for the Snakemake of a killed campaign: a sleeping orphan in its own session
    whose command line names ``snakemake`` and ``argument``; its pid."""
    orphan = (
        "import subprocess, sys; print(subprocess.Popen(sys.argv[1:], start_new_session=True, "
        "stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).pid)"
    )
    sleeper = [sys.executable, "-c", "import time; time.sleep(60)", "snakemake", argument]
    started = subprocess.run(
        [sys.executable, "-c", orphan, *sleeper], capture_output=True, text=True, check=True
    )
    return int(started.stdout)


def test_a_run_first_ends_the_snakemake_of_an_earlier_run_still_going(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(copy.deepcopy(ANALYTIC_STUDY)))
    stale = snakemake_on(f"study_file={study.files.study.resolve()}")
    other = snakemake_on(f"study_file={tmp_path / 'other' / 'study.json'}")
    try:
        time.sleep(0.5)  # both have started Python, with their command lines
        start = time.monotonic()
        assert end_earlier_runs(study) == [stale]
        assert not alive(stale) and alive(other) and time.monotonic() - start < 5
    finally:
        for pid in (stale, other):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)


def cmdline(pid: int) -> str:
    """The command line of ``pid`` ("" once it has ended)."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def session(leader: int) -> set[int]:
    """The live processes of the session that ``leader`` started (from /proc)."""
    members = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended meanwhile
        if int(fields[3]) == leader and alive(int(stat.parent.name)):
            members.add(int(stat.parent.name))
    return members


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the kernel ends it (prctl)")
def test_a_killed_sample_takes_its_snakemake_along_and_resumes_without_loss(tmp_path):
    """kill -9 of demcal sample while its simulations run: within seconds nothing of its
    Snakemake is left, and the same command then finishes every point, each simulated once."""
    config = {
        **copy.deepcopy(ANALYTIC_STUDY),
        "study": "killed",
        "replicates": 1,
        "engine": {"name": "analytic", "noise": 0.0, "duration": 2.0},
    }
    (tmp_path / "killed.yaml").write_text(yaml.safe_dump(config))
    results = str(tmp_path / "results" / "killed")
    first = demcal(tmp_path, "sample", "killed.yaml", "--points", "2")
    deadline = time.monotonic() + 60
    while not any("simulate" in cmdline(pid) for pid in descendants(first.pid)):
        assert first.poll() is None and time.monotonic() < deadline, first.communicate()
        time.sleep(0.2)
    snakemake = next(p for p in descendants(first.pid) if "-m snakemake" in cmdline(p))
    os.kill(first.pid, signal.SIGKILL)
    first.communicate()

    def left() -> set[int]:
        on_results = {
            int(entry.name)
            for entry in Path("/proc").glob("[0-9]*")
            if results in cmdline(int(entry.name)) and alive(int(entry.name))
        }
        return session(snakemake) | on_results

    deadline = time.monotonic() + 5.0  # Snakemake takes a second or two to end its jobs
    while left() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not left(), [cmdline(pid) for pid in left()]
    out = finish(demcal(tmp_path, "sample", "killed.yaml", "--points", "2"))
    assert "2 of 2 simulations finished (2 ok)" in out
    archived = finish(demcal(tmp_path, "archive", "list", "--study", "killed")).splitlines()
    assert sorted(line.split()[1] for line in archived) == ["killed/e0000", "killed/e0001"]
