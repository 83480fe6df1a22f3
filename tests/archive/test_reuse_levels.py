"""Reuse takes the coarse runs of the same material as well (issue 38, item 3): a study whose
search spends a cheaper level starts from the archive's runs of both levels; one that does
not spend it takes the fine runs only, and never a coarse run for a fine one."""

from __future__ import annotations

import copy

import pandas as pd
import pytest
from helpers import ANALYTIC_STUDY, run_calibration

from demcal.results.records import FINE, ReusedRecord

LEVELS = {"coarse": {"engine": {"cpu": 6.0, "scale": 0.9}}}


def config(name: str, spend: bool, reuse: bool) -> dict:
    study = copy.deepcopy(ANALYTIC_STUDY)
    study.update(
        study=name,
        engine={"name": "analytic", "noise": 0.002, "cpu": 60.0},
        replicates=1,
        fidelities=LEVELS,
        optimizer={
            "max_evaluations": 8,
            "stop_when_known": False,
            "kriging_restarts": 1,
            "early_termination": {"enabled": False},
            **({"fidelity": "coarse"} if spend else {}),
        },
        calibration={"poll_seconds": 0.001, "retries": 1},
        **({"reuse": "archive"} if reuse else {}),
    )
    return study


@pytest.mark.slow
def test_a_study_spending_the_level_reuses_its_coarse_runs_too(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    first = run_calibration(config("first", spend=True, reuse=False))
    ran = pd.read_csv(first.files.evaluations_csv)
    coarse_runs = int((ran["fidelity"] == "coarse").sum())
    assert coarse_runs > 0

    second = run_calibration(config("second", spend=True, reuse=True))
    points = ReusedRecord.read(second.files.reused).points
    levels = [p.get("fidelity", FINE) for p in points]
    assert levels.count("coarse") == coarse_runs and levels.count(FINE) == 8
    cheap = [r for r in second.optimizer.cheap_records if r.reused_from]
    assert len(cheap) == coarse_runs and all(r.fidelity == "coarse" for r in cheap)
    assert all(r.fidelity == FINE for r in second.optimizer.records)
    table = pd.read_csv(second.files.evaluations_csv)
    reused = table[table["origin"] == "archive"]
    assert (reused["fidelity"] == "coarse").sum() == coarse_runs

    third = run_calibration(config("third", spend=False, reuse=True))
    points = ReusedRecord.read(third.files.reused).points
    assert points and all(p.get("fidelity", FINE) == FINE for p in points)
    assert not third.optimizer.cheap_records
