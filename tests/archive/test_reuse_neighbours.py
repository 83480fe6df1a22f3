"""Reuse of neighbouring materials (issue 38, item 7): with ``reuse: neighbours`` a study takes
the archive's runs of other materials on the same simulator as data of its response models,
their differing fixed parameters as inputs; they never answer, never count as this study's
evaluations, and a study without it takes none of them."""

from __future__ import annotations

import copy

import pandas as pd
import pytest
from helpers import ANALYTIC_STUDY, run_calibration

from demcal.errors import ConfigError
from demcal.optimizer import Optimizer
from demcal.reporting.headline import report_headline
from demcal.results.records import BestRecord, FinishedRecord, ReusedRecord
from demcal.study.config import load_study


def config(name: str, density: float, reuse: str | None = None, **optimizer) -> dict:
    study = copy.deepcopy(ANALYTIC_STUDY)
    study.update(
        study=name,
        engine={"name": "analytic", "noise": 0.002},
        fixed={"restitution_pp": 0.5, "particle_density": density},
        replicates=1,
        optimizer={
            "max_evaluations": 7,
            "stop_when_known": False,
            "kriging_restarts": 1,
            **optimizer,
        },
        calibration={"poll_seconds": 0.001, "retries": 1},
        **({"reuse": reuse} if reuse else {}),
    )
    return study


def test_a_neighbouring_material_teaches_the_models_and_nothing_else(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    archived = run_calibration(config("archived", 2500.0, max_evaluations=5))
    ran = len(pd.read_csv(archived.files.evaluations_csv).query("status == 'ok'"))

    plain = run_calibration(config("plain", 2600.0, reuse="archive", max_evaluations=2))
    assert ReusedRecord.read(plain.files.reused).points == []  # not another material's runs
    assert not plain.optimizer.neighbour_records

    denser = run_calibration(config("denser", 2600.0, reuse="neighbours", max_evaluations=2))
    points = ReusedRecord.read(denser.files.reused).points
    materials = [p.get("material") for p in points]
    assert materials == [None, None] + [{"particle_density": 2500.0}] * ran  # plain's, then
    optimizer = denser.optimizer
    offsets = [r.material for r in optimizer.neighbour_records]
    assert offsets == [{"particle_density": -100.0}] * ran
    assert [r.reused_from for r in optimizer.records][:2] == ["plain/e0000", "plain/e0001"]
    assert optimizer.neighbour_records[0].reused_from == "archived/e0000 (particle_density 2500)"
    assert optimizer.completed_evaluations() == 2  # the budget is this study's runs only
    best = BestRecord.read(denser.files.best)
    assert best.evaluations == {"new": 2, "reused": 2, "neighbours": ran}
    table = pd.read_csv(denser.files.evaluations_csv)
    near = table[table["origin"] == "neighbouring material"]
    assert len(near) == ran and near["objective"].isna().all()
    assert FinishedRecord.read(denser.files.finished).neighbours == ran
    assert f"plus {ran} of neighbouring materials" in report_headline(denser.study)
    again = Optimizer.from_json(optimizer.to_json(), optimizer.objective)
    assert again.neighbour_records == optimizer.neighbour_records

    same = run_calibration(config("same", 2500.0, reuse="neighbours", max_evaluations=1))
    points = ReusedRecord.read(same.files.reused).points
    assert sum("material" not in p for p in points) == ran  # its own material: plain reuse
    assert len(same.optimizer.neighbour_records) == 4  # the 2600 kg/m^3 runs of both studies
    assert {p["material"]["particle_density"] for p in points if "material" in p} == {2600.0}


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (
            {"strategy": "dycors"},
            "reuse: 'neighbours' teaches the response models, which the dycors",
        ),
        (
            {"fidelity": "coarse"},
            "reuse: 'neighbours' cannot be combined with optimizer.fidelity",
        ),
    ],
)
def test_neighbours_need_the_search_that_uses_them(changes, message):
    study = config("bad", 2600.0, reuse="neighbours", **changes)
    study["fidelities"] = {"coarse": {"engine": {"cpu": 1.0}}}
    with pytest.raises(ConfigError, match=message):
        load_study(study)
