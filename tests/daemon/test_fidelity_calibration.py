"""A calibration that spends a cheaper fidelity level (issue 38, item 4), in this process on
the analytic engine: the cheap evaluations run at their level, the answer is a fine one,
evaluations.csv, the summary and the progress line give each level's runs and CPU; a study
that names a level it does not have, or a strategy that cannot spend one, is refused."""

from __future__ import annotations

import copy
import logging

import pandas as pd
import pytest
from helpers import ANALYTIC_STUDY, calibrate

from demcal.daemon.loop import cheaper_text
from demcal.errors import ConfigError
from demcal.reporting.terminal import level_spending
from demcal.results.records import FINE, BestRecord, PointRecord, SimulationRecord
from demcal.study.config import load_study

LEVELS = {"coarse": {"engine": {"cpu": 6.0, "scale": 0.9, "bias": {"angle_of_repose": 3.0}}}}


def leveled(**optimizer) -> dict:
    config = copy.deepcopy(ANALYTIC_STUDY)
    config["engine"] = {"name": "analytic", "noise": 0.005, "cpu": 60.0}
    config["replicates"] = 1
    config["fidelities"] = LEVELS
    config["optimizer"] = {
        "max_evaluations": 9,
        "fidelity": "coarse",
        "stop_when_known": False,
        "kriging_restarts": 1,
        "early_termination": {"enabled": False},
        **optimizer,
    }
    config["calibration"] = {"poll_seconds": 0.001, "retries": 1}
    return config


@pytest.mark.slow
def test_a_calibration_spends_the_cheap_level_and_answers_from_fine_runs(
    tmp_path, monkeypatch, caplog
):
    monkeypatch.chdir(tmp_path)
    caplog.set_level(logging.INFO, logger="demcal")
    calibration, runner, reason = calibrate(leveled())
    study = calibration.study
    table = pd.read_csv(study.files.evaluations_csv)
    assert set(table["fidelity"]) == {FINE, "coarse"}
    cheap = table[table["fidelity"] == "coarse"]
    assert len(table[table["fidelity"] == FINE]) == 9 and len(cheap) >= 5
    assert set(cheap["cpu_s"]) == {6.0}
    name = cheap["evaluation"].iloc[0]
    assert PointRecord.read(study.files.evaluation(name).params).fidelity == "coarse"
    simulation = SimulationRecord.read(
        study.files.evaluation(name).replicate("cylinder_lift", 0).simulation
    )
    assert simulation.fidelity == "coarse" and simulation.simulator["settings"]["scale"] == 0.9
    best = BestRecord.read(study.files.best)
    assert best.evaluation in set(table[table["fidelity"] == FINE]["evaluation"])
    assert cheaper_text(calibration.optimizer).startswith(f"+{len(cheap)} coarse, pays for ")
    assert "level coarse pays for cylinder_lift.angle_of_repose" in caplog.text
    assert level_spending(study).startswith(
        f"by level: fine 9 evaluations (9 min CPU), coarse {len(cheap)} evaluations ("
    )


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"fidelity": "nope"}, "optimizer.fidelity: 'nope' is not a cheaper level"),
        (
            {"strategy": "dycors"},
            "optimizer.fidelity: the dycors strategy cannot spend a cheaper level",
        ),
        ({"fidelity": 3}, "optimizer.fidelity: 3 is not a level's name"),
    ],
)
def test_a_search_level_the_study_cannot_spend_is_refused(changes, message):
    with pytest.raises(ConfigError, match=message):
        load_study(leveled(**changes))
