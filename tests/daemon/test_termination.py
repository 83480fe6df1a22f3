"""The early-termination watch: estimates read from partial.csv files written by hand, and the
decisions of Samuelsson's (2023) rule (eq. 3.4) on them against a given best value."""

from __future__ import annotations

import csv

import pytest
from helpers import analytic_example, write_partial

from demcal.daemon.termination import (
    append_estimates,
    early_termination_decisions,
    latest_estimates,
    partial_responses,
    share_done,
)
from demcal.optimizer.early_termination import early_termination_decision
from demcal.optimizer.objective import estimated_objective
from demcal.results.layout import ESTIMATE_COLUMNS, EvaluationFiles
from demcal.study.config import load_study

ANGLE, DENSITY = "cylinder_lift.angle_of_repose", "cylinder_lift.bulk_density"


@pytest.fixture
def files(tmp_path) -> EvaluationFiles:
    return EvaluationFiles(tmp_path / "evals" / "e0003")


def test_the_latest_estimate_of_each_replicate_is_read(files):
    write_partial(
        files,
        0,
        [
            ("0.1", "0.1", "fill", "", "", ""),  # progress only
            ("0.5", "0.3", "fill", "bulk_density", "1500.0", "0"),
            ("0.9", "0.5", "fill", "bulk_density", "1480.0", "1"),
            ("1.2", "0.7", "lift", "angle_of_repose", "31.0", "0"),
        ],
    )
    write_partial(files, 1, [("0.4", "0.5", "fill", "bulk_density", "1460.0", "1")])
    assert latest_estimates(files, ["cylinder_lift"], 2) == {
        DENSITY: [1480.0, 1460.0],
        ANGLE: [31.0],
    }
    assert partial_responses(files, ["cylinder_lift"], 2) == {
        DENSITY: {"values": [1480.0, 1460.0], "final": True},
        ANGLE: {"values": [31.0], "final": False},
    }


def test_share_done_counts_finished_running_and_waiting_simulations(files):
    """Three replicates: one finished (responses.json), one 40 % through, one not started."""
    write_partial(files, 0, [("5.0", "1.0", "lift", "angle_of_repose", "31.0", "1")])
    files.replicate("cylinder_lift", 0).responses.write_text("{}")
    write_partial(files, 1, [("2.0", "0.4", "fill", "bulk_density", "1500.0", "0")])
    assert share_done(files, ["cylinder_lift"], 3) == pytest.approx((1.0 + 0.4 + 0.0) / 3)


def test_each_poll_reads_on_from_where_the_last_stopped(files):
    write_partial(files, 0, [("0.2", "0.5", "lift", "angle_of_repose", "30.0", "0")])
    assert latest_estimates(files, ["cylinder_lift"], 1) == {ANGLE: [30.0]}
    path = files.replicate("cylinder_lift", 0).partial
    with open(path, "a") as handle:  # a line the run is still writing: not read yet
        handle.write("0.4,0.8,lift,angle_of_repose,28.")
    assert latest_estimates(files, ["cylinder_lift"], 1) == {ANGLE: [30.0]}
    with open(path, "a") as handle:
        handle.write("5,1\n")
    assert latest_estimates(files, ["cylinder_lift"], 1) == {ANGLE: [28.5]}
    assert partial_responses(files, ["cylinder_lift"], 1) == {
        ANGLE: {"values": [28.5], "final": True}
    }


def test_a_rewritten_partial_csv_is_read_from_its_start(files):
    write_partial(files, 0, [("0.2", "0.5", "lift", "angle_of_repose", "30.0", "0")])
    assert latest_estimates(files, ["cylinder_lift"], 1) == {ANGLE: [30.0]}
    path = files.replicate("cylinder_lift", 0).partial
    path.unlink()  # a retry starts the simulation over: a new file, nothing estimated yet
    write_partial(files, 0, [("0.1", "0.1", "fill", "", "", "")])
    assert latest_estimates(files, ["cylinder_lift"], 1) == {}


def test_replicates_without_a_file_or_a_value_give_no_estimate(files):
    write_partial(
        files, 1, [("0.1", "0.2", "fill", "bulk_density", "", "0"), ("x", "", "", "", "", "")]
    )
    assert latest_estimates(files, ["cylinder_lift"], 2) == {}
    assert partial_responses(files, ["cylinder_lift"], 2) == {}


def decide_against(best: float, progress: float = 0.0):
    """The rule with a given best value f*; records which evaluations it was asked about."""
    asked = []

    def decide(evaluation, estimate):
        asked.append(evaluation)
        return early_termination_decision(best, estimate, progress)

    return decide, asked


def test_decisions_against_a_given_limit():
    decide, asked = decide_against(0.02)  # c = 10 before half the budget: limit 0.2
    decisions = early_termination_decisions({"e0004": 0.5, "e0005": 0.1, "e0006": None}, decide)
    assert asked == ["e0004", "e0005"]  # nothing estimated yet: not asked
    assert set(decisions) == {"e0004", "e0005"}
    assert decisions["e0004"].stop and decisions["e0004"].limit == pytest.approx(0.2)
    assert not decisions["e0005"].stop and decisions["e0005"].limit == pytest.approx(0.2)
    late, _ = decide_against(0.02, progress=0.9)  # c = 2.5 at the end: limit 0.05
    assert early_termination_decisions({"e0005": 0.1}, late)["e0005"].stop


def test_estimates_from_partial_files_to_a_stop(files):
    study = load_study(analytic_example())  # targets: angle 25 deg, bulk density 1450 kg/m^3
    write_partial(files, 0, [("0.5", "0.5", "fill", "bulk_density", "1450.0", "1")])
    write_partial(files, 1, [("0.6", "0.6", "lift", "angle_of_repose", "35.0", "0")])
    estimates = latest_estimates(files, list(study.scenes), study.replicates)
    estimate = estimated_objective(study.targets, estimates, 0.0, study.objective_form)
    assert estimate == pytest.approx(((35.0 - 25.0) / 25.0) ** 2)  # 0.16: density on target
    decide, _ = decide_against(0.01)  # limit 10 x 0.01 = 0.1 < 0.16
    (decision,) = early_termination_decisions({files.id: estimate}, decide).values()
    assert decision.stop
    assert decision.limit == pytest.approx(0.1)
    decide, _ = decide_against(0.02)  # limit 0.2 > 0.16
    assert not early_termination_decisions({files.id: estimate}, decide)[files.id].stop


def test_the_trace_gets_its_header_once_and_no_file_without_rows(tmp_path):
    path = tmp_path / "early_termination.csv"
    append_estimates(path, [])
    assert not path.exists()
    append_estimates(path, [("1.0", "e0004", "0.5", "0.5", "0.2", 1, "0.5")])
    append_estimates(path, [("2.0", "e0005", "1.5", "0.1", "", 0, "")])
    with open(path, newline="") as handle:
        assert list(csv.reader(handle)) == [
            list(ESTIMATE_COLUMNS),
            ["1.0", "e0004", "0.5", "0.5", "0.2", "1", "0.5"],
            ["2.0", "e0005", "1.5", "0.1", "", "0", ""],
        ]


def test_a_trace_begun_before_the_judged_column_keeps_its_columns(tmp_path):
    path = tmp_path / "early_termination.csv"
    path.write_text("elapsed_s,evaluation,running_s,estimate,limit,stop\n1.0,e0004,0.5,0.5,0.2,1\n")
    append_estimates(path, [("2.0", "e0005", "1.5", "0.1", "0.3", 0, "0.1")])
    assert path.read_text().splitlines()[-1] == "2.0,e0005,1.5,0.1,0.3,0"
