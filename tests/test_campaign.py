"""Sampling campaigns (issue 22, item 1): space-filling designs, their measures, extension,
and ``demcal sample`` on the analytic engine."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml
from conftest import ANALYTIC_STUDY, demcal, finish

from demcal.campaign import check_request, plan, tally, write_points
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
    assert plan(study, 4, "fssf_f") == first  # a smaller --n changes nothing
    with pytest.raises(ConfigError, match="--design sobol: the campaign .* is a fssf_f design"):
        plan(study, 10, "sobol")
    CampaignRecord("latin_hypercube", 1, first.unit_points).write(study.files.campaign)
    with pytest.raises(ConfigError, match="cannot be extended and stay space-filling"):
        plan(study, 10, "latin_hypercube")
    with pytest.raises(ConfigError, match="--n 1: give at least 2 points"):
        plan(study, 1, "sobol")
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
    out = finish(demcal(tmp_path, "sample", "campaign.yaml", "--n", "4"))
    assert "fssf_f design of 4 points in 2 parameters" in out
    assert "4 of 4 simulations finished (4 ok)" in out
    assert len(finish(demcal(tmp_path, "archive", "list", "--of", "campaign")).splitlines()) == 4
    failing = {
        **config,
        "study": "failing",
        "engine": {
            "name": "analytic",
            "failures": [{"when": {"sliding_friction_pp": [0.0, 1.0]}, "reason": "mesh broke"}],
        },
    }
    (tmp_path / "failing.yaml").write_text(yaml.safe_dump(failing))
    stopped = demcal(tmp_path, "sample", "failing.yaml", "--n", "40")
    _, err = stopped.communicate(timeout=240)
    assert stopped.returncode == 1
    assert "the first 5 simulations all failed (commonest: mesh broke)" in err
