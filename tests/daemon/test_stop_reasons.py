"""A stopped evaluation says who stopped it and why: early termination with the estimate and
the limit it missed, `demcal stop`, or a STOP file made by hand."""

from __future__ import annotations

import time
from dataclasses import dataclass

import pytest
from helpers import InProcessLauncher, config, evaluate, write_partial

from demcal.daemon.control import request_stop
from demcal.daemon.loop import Calibration
from demcal.jobs.steps import STOPPED_BY_HAND, ask_to_stop
from demcal.results.layout import evaluation_id
from demcal.results.records import ObjectiveRecord, PointRecord, Status
from demcal.results.storage import write_json
from demcal.study.config import load_study
from demcal.study.model import freeze


@dataclass
class StillRunning:
    """An evaluation whose simulations are running (its child Snakemake has not ended)."""

    evaluation: str
    started: float
    pid: int = -1

    def finished(self) -> bool:
        return False


@pytest.fixture
def study(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = config()
    study["optimizer"] = {
        "max_evaluations": 8,
        "response_model": "cubic_rbf",
        "early_termination": {"thresholds": [1.0], "progress_boundaries": []},
    }
    return freeze(load_study(study))


def stopped_reason(study, evaluation: str) -> str:
    """The reason the objective job records for an evaluation whose simulations see its STOP."""
    InProcessLauncher(study).launch(study.files.evaluation(evaluation))
    record = ObjectiveRecord.read(study.files.evaluation(evaluation).objective)
    assert record.status == Status.TERMINATED
    return record.reason


def test_early_termination_names_the_estimate_and_the_limit_it_missed(study):
    calibration = Calibration(study, InProcessLauncher(study), workers=1)
    optimizer = calibration.optimizer
    for proposal in optimizer.ask(optimizer.initial_size):
        evaluate(study, optimizer, proposal)
    (proposal,) = optimizer.ask(1)  # after the initial design: early termination may stop it
    evaluation = evaluation_id(proposal.id)
    calibration.write_point(proposal)
    calibration.children[evaluation] = StillRunning(evaluation, time.time())
    files = study.files.evaluation(evaluation)
    for replicate in range(2):  # far from the targets (25 deg, 1450 kg/m^3) half way through
        write_partial(
            files,
            replicate,
            [
                ("0.5", "0.5", "fill", "bulk_density", "900.0", "1"),
                ("0.5", "0.5", "lift", "angle_of_repose", "60.0", "0"),
            ],
        )
    calibration.watch.check(calibration.children)
    reason = files.stop.read_text()
    assert reason.startswith("stopped early by early termination: partial estimate ")
    assert " > 1 x best " in reason  # the limit: c = 1 times the best objective
    assert stopped_reason(study, evaluation) == reason


def test_demcal_stop_names_itself_and_keeps_an_earlier_reason(study):
    running, stopped_early, done = (study.files.evaluation(f"e000{i}") for i in range(3))
    for files in (running, stopped_early, done):
        PointRecord({"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.1}).write(files.params)
        write_json(files.launch, {"pid": 1, "started_at": time.time()})
    ask_to_stop(stopped_early, "stopped early by early termination: partial estimate 2 > 1")
    ObjectiveRecord(done.id, Status.OK, objective=0.1).write(done.objective)
    request_stop(study)
    assert running.stop.read_text() == "stopped by demcal stop"
    assert stopped_early.stop.read_text().startswith("stopped early by early termination")
    assert not done.stop.exists()  # ended already: nothing to stop
    assert stopped_reason(study, "e0000") == "stopped by demcal stop"


def test_a_stop_file_made_by_hand_gives_no_reason_and_says_so(study):
    files = study.files.evaluation("e0000")
    PointRecord({"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.1}).write(files.params)
    files.stop.touch()
    assert stopped_reason(study, "e0000") == STOPPED_BY_HAND
