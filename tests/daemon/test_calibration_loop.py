"""The calibration loop in-process: a launcher that runs each evaluation's jobs here.

No Snakemake and no subprocess: ``Calibration`` takes the launcher, so its
bookkeeping (proposals, records, retries, re-scoring, the tables and
finished.json) is tested directly and deterministically.
"""

from __future__ import annotations

import copy
import json
import time
from dataclasses import dataclass

import pandas as pd
import pytest
from helpers import (
    TRUTH,
    InProcessLauncher,
    calibrate,
    config,
    run_last_jobs,
    run_simulations,
    true_targets,
)

from demcal.daemon.loop import Calibration
from demcal.errors import ConfigError, DemcalError
from demcal.results.layout import EvaluationFiles, evaluation_id
from demcal.results.records import (
    FinishedRecord,
    LaunchRecord,
    ObjectiveRecord,
    PointRecord,
    ResponsesRecord,
    Status,
)
from demcal.study.config import load_study
from demcal.study.model import Study, freeze


def evaluations_table(study_name: str) -> pd.DataFrame:
    table = pd.read_csv(f"results/{study_name}/evaluations.csv")
    return table.drop(columns=["started_at", "ended_at", "wall_s", "cpu_s"])  # measured times


def test_the_loop_runs_the_budget_and_writes_every_record(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    calibration, runner, reason = calibrate(config())
    assert reason == "evaluation budget reached (8 of 8)"
    assert runner.launched == [f"e{i:04d}" for i in range(8)]
    finished = FinishedRecord.read(calibration.files.finished)
    assert finished.reason == reason and finished.count(Status.OK) == 8
    table = evaluations_table("unit")
    assert list(table["status"]) == ["ok"] * 8
    told = {r.id: r.value for r in calibration.optimizer.records}
    for files in calibration.files.evaluations():
        record = ObjectiveRecord.read(files.objective)
        assert record.scored_with == calibration.study.objective.version
        assert told[int(files.id[1:])] == record.objective
    best = json.loads(calibration.files.best.read_text())
    assert best["objective"] == told[int(best["evaluation"][1:])]


@dataclass
class UnawareChild:
    """A child whose jobs have written every responses.json but whose Snakemake has not seen
    them end yet (through SLURM: until the executor's next status check); at the
    ``polls``-th question it runs its objective and archive jobs and ends."""

    files: EvaluationFiles
    started: float
    study: Study
    polls: int
    pid: int = -1
    writes: bool = True  # False: killed before its objective and archive jobs

    @property
    def evaluation(self) -> str:
        return self.files.id

    def finished(self) -> bool:
        self.polls -= 1
        if self.polls > 0:
            return False
        if self.writes:
            run_last_jobs(self.study, self.files)
        return True

    def returncode(self) -> int | None:
        return 0


@dataclass
class SlowToEndLauncher(InProcessLauncher):
    """Runs the simulate and extract jobs not run yet at launch; each child then takes
    ``polls`` polls to run its objective and archive jobs and end; the first ``kills`` children
    of each evaluation in ``killed`` end without them."""

    polls: int = 4
    killed: tuple[str, ...] = ()
    kills: int = 1

    def launch(self, files: EvaluationFiles) -> UnawareChild:
        self.launched.append(files.id)
        self.unaware_at_launch.append(
            sorted(c.evaluation for c in self.children if c.polls > 0 and c.evaluation != files.id)
        )
        run_simulations(self.study, files)
        child = UnawareChild(files, time.time(), self.study, self.polls, pid=len(self.launched))
        LaunchRecord(child.pid, child.started).write(files.launch)  # as the Snakemake launcher
        child.writes = files.id not in self.killed or self.launched.count(files.id) > self.kills
        self.children.append(child)
        return child

    def __post_init__(self):
        super().__post_init__()
        self.children: list[UnawareChild] = []
        self.unaware_at_launch: list[list[str]] = []


def test_an_evaluation_is_taken_from_its_responses_before_its_snakemake_ends(tmp_path, monkeypatch):
    """The daemon does not wait for a child to see its jobs end: the next point is launched
    while the last child still waits; the calibration still ends with every record written,
    the same as with children that end at once."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(config()))
    runner = SlowToEndLauncher(study)
    calibration = Calibration(study, runner, workers=1)
    reason = calibration.run(show_progress=lambda progress: None)
    assert reason == "evaluation budget reached (8 of 8)"
    for i, unaware in enumerate(runner.unaware_at_launch[1:]):
        assert f"e{i:04d}" in unaware  # launched before e{i}'s Snakemake saw its end
    assert all(child.polls <= 0 for child in runner.children)  # none left behind
    assert not calibration.ending
    table = evaluations_table("unit")
    assert list(table["status"]) == ["ok"] * 8
    (tmp_path / "at_once").mkdir()
    monkeypatch.chdir(tmp_path / "at_once")
    runner = InProcessLauncher(study)
    Calibration(study, runner, workers=1).run(show_progress=lambda progress: None)
    pd.testing.assert_frame_equal(evaluations_table("unit"), table)


def test_a_child_killed_before_its_last_jobs_is_launched_again_to_run_them(tmp_path, monkeypatch):
    """A taken evaluation's child that ends (killed) before its objective and archive jobs is
    launched again, once, to run them; the calibration ends with every record written, each by
    its job."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(config()))
    runner = SlowToEndLauncher(study, polls=3, killed=("e0001", "e0004"))
    calibration = Calibration(study, runner, workers=2)
    assert calibration.run(show_progress=lambda progress: None).startswith("evaluation budget")
    assert sorted(runner.launched) == sorted([f"e{i:04d}" for i in range(8)] + ["e0001", "e0004"])
    for evaluation in ("e0001", "e0004"):  # launch.json: the new child, the first one's start
        first, again = [c for c in runner.children if c.evaluation == evaluation]
        launch = LaunchRecord.read(calibration.files.evaluation(evaluation).launch)
        assert (launch.pid, launch.started_at) == (again.pid, first.started)
    told = {evaluation_id(r.id): r.value for r in calibration.optimizer.records}
    for files in calibration.files.evaluations():
        assert ObjectiveRecord.read(files.objective).objective == told[files.id]
        assert files.archived.exists()
    assert list(evaluations_table("unit")["status"]) == ["ok"] * 8


def test_a_child_killed_again_leaves_the_calibration_to_the_next_run(tmp_path, monkeypatch):
    """A taken evaluation's child launched again that also ends before its last jobs is not
    launched a third time: the daemon ends, saying so, the calibration unfinished; the same
    command launches it again and finishes."""
    monkeypatch.chdir(tmp_path)
    settings = config()
    settings["optimizer"]["max_evaluations"] = 3
    study = freeze(load_study(settings))
    runner = SlowToEndLauncher(study, polls=2, killed=("e0001",), kills=2)
    with pytest.raises(DemcalError, match="child Snakemake of e0001 ended twice without writing"):
        Calibration(study, runner, workers=1).run(show_progress=lambda progress: None)
    assert runner.launched.count("e0001") == 2 and not study.files.finished.exists()
    again = Calibration(study, runner, workers=1)
    assert again.run(show_progress=lambda progress: None).startswith("evaluation budget")
    assert runner.launched.count("e0001") == 3
    assert study.files.evaluation("e0001").objective.exists()


def test_failures_and_an_earlier_attempts_responses_are_not_taken_early(tmp_path, monkeypatch):
    """A failed simulation waits for the child (its log says why, a retry needs it gone), and
    responses a job of an earlier attempt wrote into a retry's folders are not the retry's."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(config()))
    calibration = Calibration(study, SlowToEndLauncher(study, polls=10**6), workers=1)
    calibration.resume()
    calibration.propose()
    files = calibration.files.evaluation("e0000")
    assert calibration.taken_early("e0000") is not None
    responses = files.replicate("cylinder_lift", 0).responses
    kept = responses.read_text()
    ResponsesRecord(Status.FAILED, "node lost").write(responses)
    assert calibration.taken_early("e0000") is None
    responses.write_text(kept)
    PointRecord.read(files.params).retried("node lost").write(files.params)
    assert calibration.taken_early("e0000") is None


def test_a_pending_evaluation_whose_responses_are_in_is_collected_on_resume(tmp_path, monkeypatch):
    """A daemon killed after an evaluation's jobs wrote every responses.json, before it took
    them, and its child gone too: the next daemon takes them and launches the child again for
    its objective and archive jobs only."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(config()))
    first = Calibration(study, SlowToEndLauncher(study, polls=10**6), workers=1)
    first.resume()
    first.propose()  # launched; the daemon dies before its next poll
    simulation = first.files.evaluation("e0000").replicate("cylinder_lift", 0).simulation
    simulated = simulation.read_text()
    runner = InProcessLauncher(study)
    again = Calibration(study, runner, workers=1)
    again.resume()
    again.collect()
    assert runner.launched == ["e0000"] and simulation.read_text() == simulated
    record = next(r for r in again.optimizer.records if r.id == 0)
    assert record.status == Status.OK
    assert ObjectiveRecord.read(again.files.evaluation("e0000").objective).objective == record.value


def test_a_daemon_killed_before_a_taken_evaluation_was_written_relaunches_its_child(
    tmp_path, monkeypatch
):
    """A daemon that ends while a taken evaluation's child has not written objective.json
    (both killed): the next daemon launches the child again, which writes it from the
    responses, simulating nothing again."""
    monkeypatch.chdir(tmp_path)
    settings = config()
    settings["optimizer"]["max_evaluations"] = 3
    study = freeze(load_study(settings))
    runner = SlowToEndLauncher(study, polls=10**6)
    calibration = Calibration(study, runner, workers=1)
    calibration.resume()
    calibration.propose()
    calibration.collect()
    assert list(calibration.ending) == ["e0000"]
    best = json.loads(calibration.files.best.read_text())
    assert best["evaluation"] == "e0000"  # written from the record taken
    files = calibration.files.evaluation("e0000")
    assert not files.objective.exists()
    simulated = files.replicate("cylinder_lift", 0).simulation.read_text()
    again = Calibration(study, runner, workers=1)
    again.resume()
    assert list(again.ending) == ["e0000"] and runner.launched == ["e0000", "e0000"]
    runner.children[1].polls = 1  # its Snakemake sees the end: it runs the objective job
    again.collect()
    told = next(r for r in again.optimizer.records if r.id == 0)
    assert ObjectiveRecord.read(files.objective).objective == told.value
    assert files.replicate("cylinder_lift", 0).simulation.read_text() == simulated
    assert not again.ending


def test_same_seed_same_evaluations(tmp_path, monkeypatch):
    tables = []
    for run in ("a", "b"):
        (tmp_path / run).mkdir()
        monkeypatch.chdir(tmp_path / run)
        calibrate(config())
        tables.append(evaluations_table("unit"))
    pd.testing.assert_frame_equal(*tables)
    (tmp_path / "c").mkdir()
    monkeypatch.chdir(tmp_path / "c")
    calibrate(config(seed=4))
    assert not evaluations_table("unit")["objective"].equals(tables[0]["objective"])


def test_a_failed_evaluation_is_retried_with_its_reason_kept(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    calibration, runner, _ = calibrate(config(), fail=("e0001",))
    assert runner.launched.count("e0001") == 2
    point = json.loads(calibration.files.evaluation("e0001").params.read_text())
    assert point["attempt"] == 1 and point["previous_failures"] == ["node lost"]
    assert evaluations_table("unit").set_index("evaluation").loc["e0001", "status"] == "ok"


def test_corrected_targets_rescore_into_their_own_record(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    first, _, _ = calibrate(config())
    jobs = {f.id: f.objective.read_text() for f in first.files.evaluations()}
    changed = config()
    changed["targets"] = copy.deepcopy(changed["targets"])
    changed["targets"][0]["value"] = 26.0
    second = Calibration(freeze(load_study(changed)), InProcessLauncher(first.study), workers=2)
    assert {f.id: f.objective.read_text() for f in second.files.evaluations()} == jobs
    for files in second.files.evaluations():
        rescored = ObjectiveRecord.read(files.rescored)
        assert rescored.scored_with == second.study.objective.version
        angle = rescored.responses["cylinder_lift.angle_of_repose"]
        density = rescored.responses["cylinder_lift.bulk_density"]
        expected = ((angle - 26.0) / 26.0) ** 2 + ((density - 1450.0) / 1450.0) ** 2
        assert rescored.objective == pytest.approx(expected, rel=1e-12)


def test_explore_after_the_end_maps_the_set_on_the_next_run(tmp_path, monkeypatch, capsys):
    from demcal.analysis.solution_report import check_point, write_solutions
    from demcal.cli.analysis import print_point_check
    from demcal.daemon.control import explore_solutions
    from demcal.optimizer.membership import LIKELY, POSSIBLE

    monkeypatch.chdir(tmp_path)
    spreads = {"angle_of_repose": 1.0, "bulk_density": 10.0}
    targets = [{**t, "spread": spreads[t["response"]]} for t in true_targets()]  # at TRUTH
    calibration, runner, reason = calibrate(config(targets=targets))
    assert reason == "evaluation budget reached (8 of 8)"
    explore_solutions(calibration.study, 3)
    assert not calibration.files.finished.exists()  # the next run of the same command goes on
    again = Calibration(calibration.study, runner, workers=2)
    reason = again.run(show_progress=lambda progress: None)
    assert (
        reason
        == "exploring the solution set was asked for; then 3 evaluations mapped the solution set"
    )
    assert runner.launched[8:] == ["e0008", "e0009", "e0010"]
    assert [r.maps_solutions for r in again.optimizer.records] == [False] * 8 + [True] * 3
    analysis = write_solutions(calibration.study, samples=1024)
    assert {v.verdict for v in analysis.verdicts} <= {
        "pinned",
        "partly identified",
        "not identified",
        "not established",
    }
    assert "likely" in json.loads(calibration.files.solutions_summary.read_text())
    # demcal solutions --point: the truth meets the targets, a far corner does not
    assert check_point(analysis, TRUTH).probability >= LIKELY
    print_point_check(calibration.study, analysis, TRUTH)
    out = capsys.readouterr().out
    assert "sliding_friction_pp=0.4, rolling_friction_pp=0.1: probability " in out
    assert "in the solution set\n  cylinder_lift.angle_of_repose: predicted " in out
    corner = check_point(analysis, {"sliding_friction_pp": 0.9, "rolling_friction_pp": 0.3})
    assert corner.probability < POSSIBLE
    with pytest.raises(ConfigError, match="give every free parameter; rolling_friction_pp is"):
        check_point(analysis, {"sliding_friction_pp": 0.3})
    with pytest.raises(
        ConfigError, match=r"sliding_friction_pp=1.2: outside its bounds \[0.1, 0.9\]"
    ):
        check_point(analysis, {"sliding_friction_pp": 1.2, "rolling_friction_pp": 0.1})
