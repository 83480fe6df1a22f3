"""A simulation at a fidelity level (issue 38, items 1, 3 and 6): the simulate job runs the
level's settings, time step and engine, records its level, and the archive keeps the level
and the fine level it belongs to; a campaign runs its points at each of its levels."""

from __future__ import annotations

import copy

import pytest
from helpers import ANALYTIC_STUDY, run_last_jobs, run_simulations

from demcal.archive.simulation import digest
from demcal.archive.store import Archive
from demcal.cli.archive import line
from demcal.domain.campaign import plan, point_names, write_points
from demcal.errors import ConfigError
from demcal.results.records import FINE, PointRecord, SimulationRecord
from demcal.study.config import load_study
from demcal.study.model import freeze

LEVELS = {
    "coarse": "default",
    "loose": {"timestep_fraction": 0.3, "engine": {"scale": 0.5, "cpu": 2.0}},
}


@pytest.fixture
def leveled(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return freeze(
        load_study(
            {
                **copy.deepcopy(ANALYTIC_STUDY),
                "replicates": 1,
                "fidelities": LEVELS,
                "archive": {"url": "sqlite:///results/archive.sqlite"},
            }
        )
    )


def test_a_point_at_a_level_runs_and_is_archived_as_that_level(leveled):
    point = {"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.1}
    for name, fidelity in (("e0000", None), ("e0001", "coarse"), ("e0002", "loose")):
        files = leveled.files.evaluation(name)
        PointRecord(point, fidelity=fidelity).write(files.params)
        run_simulations(leveled, files)
        run_last_jobs(leveled, files)
    sims = {
        name: SimulationRecord.read(
            leveled.files.evaluation(name).replicate("cylinder_lift", 0).simulation
        )
        for name in ("e0000", "e0001", "e0002")
    }
    assert sims["e0000"].fidelity is None and sims["e0001"].fidelity == "coarse"
    assert sims["e0001"].settings["particle_count"] == 500
    assert sims["e0002"].timestep_fraction == 0.3
    assert sims["e0002"].simulator["settings"]["scale"] == 0.5
    assert sims["e0002"].cost["cpu_s"] == 2.0
    with Archive(leveled.archive) as archive:
        records = {r.evaluation: r for r in archive.records()}
    assert {n: r.fidelity for n, r in records.items()} == {
        "e0000": FINE,
        "e0001": "coarse",
        "e0002": "loose",
    }
    assert " cylinder_lift [coarse] rep0 ok " in line(records["e0001"])
    assert " cylinder_lift rep0 ok " in line(records["e0000"])
    fine_level = digest(leveled.fine_level_view("cylinder_lift"))
    assert {r.fine_level for r in records.values()} == {fine_level}
    # a level's runs are not the fine level's: reuse finds only the fine one
    from demcal.archive.reuse import compatible_simulations

    with Archive(leveled.archive) as archive:
        found = compatible_simulations(leveled, archive)
    assert [r.evaluation for r in found] == ["e0000"]


def test_a_point_naming_an_unknown_level_fails_with_the_reason(leveled):
    files = leveled.files.evaluation("e0000")
    PointRecord({"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.1}, fidelity="nope").write(
        files.params
    )
    run_simulations(leveled, files)
    sim = SimulationRecord.read(files.replicate("cylinder_lift", 0).simulation)
    assert sim.status == "failed"
    assert "fidelity 'nope': the study has no such level (fine, coarse, loose)" in sim.reason


def test_a_campaign_runs_each_point_at_each_of_its_levels(leveled):
    campaign = plan(leveled, 3, "sobol", [FINE, "coarse"])
    names = write_points(leveled, campaign)
    assert names == point_names(campaign) == [f"e000{i}" for i in range(6)]
    points = [PointRecord.read(leveled.files.evaluation(n).params) for n in names]
    assert [p.level for p in points] == [FINE, "coarse"] * 3
    assert points[0].parameters == points[1].parameters != points[2].parameters
    campaign.write(leveled.files.campaign)
    with pytest.raises(ConfigError, match="runs at fine, coarse, not loose"):
        plan(leveled, 3, "sobol", ["loose"])
