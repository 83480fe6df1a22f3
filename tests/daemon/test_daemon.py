"""The calibration daemon end to end on the analytic engine (child Snakemake per evaluation)."""

import errno
import itertools
import json
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers import ROOT, TRUTH, demcal, evaluations, finish, study

from demcal.study.model import load_frozen


@pytest.mark.slow
def test_local_calibration_reaches_the_known_optimum(tmp_path):
    """20 evaluations get the responses within about 3 % of the targets (objective 0 at TRUTH).

    The two responses pin the two parameters only along a shallow valley, so
    the found point is near the valley, not necessarily at TRUTH: the
    optimizer's own quality is measured in benchmarks/optimizer.
    """
    config = study(
        tmp_path,
        "conv",
        optimizer={
            "max_evaluations": 20,
            "confirm_replicates": 2,
            "early_termination": {"enabled": False},
        },
    )
    out = finish(demcal(tmp_path, "run", config, "--profile", ROOT / "profiles" / "local"))
    best = json.loads((tmp_path / "results/conv/best.json").read_text())
    table = evaluations(tmp_path, "conv")
    assert len(table) == 22 and set(table["status"]) == {
        "ok"
    }  # 20 + 2 re-simulations of the best point
    assert best["stop_reason"] == "evaluation budget reached (20 of 20)"
    assert best["units"] == {
        "sliding_friction_pp": "-",
        "rolling_friction_pp": "-",
        "cylinder_lift.angle_of_repose": "deg",
        "cylinder_lift.bulk_density": "kg/m^3",
    }
    # evaluations.csv: ISO times, a duration, short numbers; units in the sidecar
    text = (tmp_path / "results/conv/evaluations.csv").read_text()
    assert re.search(r",20\d\d-\d\d-\d\dT\d\d:\d\d:\d\dZ,20\d\d-", text)
    mantissas = re.findall(r"(?<![\w.])(\d+\.\d+)(?:e[-+]\d+)?(?![\w.])", text)
    assert (
        mantissas and max(len(m.replace(".", "").lstrip("0")) for m in mantissas) <= 7
    )  # not 0.8611111111111112
    assert (table["wall_s"] > 0).all()
    columns = pd.read_csv(tmp_path / "results/conv/evaluations.columns.csv")
    assert list(columns["column"]) == list(table.columns)
    assert columns.set_index("column").loc["cylinder_lift.bulk_density", "unit"] == "kg/m^3"
    confirmation = best["confirmation"]
    assert confirmation["of"] == best["evaluation"] and confirmation["evaluations"] == [
        "e0020",
        "e0021",
    ]
    assert confirmation["responses"]["cylinder_lift.bulk_density"]["count"] == 2
    assert f"confirmed by 2 more simulations of {best['evaluation']} (e0020, e0021; 0 failed" in out
    again = json.loads((tmp_path / "results/conv/evals/e0021/params.json").read_text())
    assert again["parameters"] == pytest.approx(best["parameters"])
    assert best["objective"] < 2e-3  # responses within about 3 % of the targets
    assert "evaluation budget reached (20 of 20)" in out
    assert "cylinder_lift.angle_of_repose [deg]" in out

    # the solution space on the same response models: targets without a spread on a
    # noise-free engine allow a set of no width, and the verdicts say so instead of a range
    out = finish(demcal(tmp_path, "solutions", config, "--samples", 4096))
    assert all(f"  {name}: no verdict" in out for name in TRUTH)
    assert "give each target the spread of its measurement" in out
    for figure in (
        "solution_space.png",
        "sensitivity.png",
        "sensitivity.csv",
        "objective_slices.png",
    ):
        assert (tmp_path / "results/conv/plots" / figure).stat().st_size > 0


@pytest.mark.slow
def test_kill_9_then_resume_loses_and_repeats_nothing(tmp_path):
    config = study(tmp_path, "crash")
    evals = tmp_path / "results" / "crash" / "evals"
    proc = demcal(tmp_path, "run", config)
    deadline = time.monotonic() + 120
    while len(list(evals.glob("*/objective.json"))) < 4 and time.monotonic() < deadline:
        time.sleep(0.2)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    # what a redone evaluation would change: its records (times, seeds, results)
    done_before = {
        p.parent.name: (
            p.read_text(),
            (p.parent / "cylinder_lift/rep0/simulation.json").read_text(),
        )
        for p in evals.glob("*/objective.json")
    }
    assert len(done_before) >= 4
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "crash")
    assert sorted(table["evaluation"]) == [f"e{i:04d}" for i in range(14)]
    assert set(table["status"]) <= {"ok", "terminated"}
    for name, records in done_before.items():
        assert (
            (evals / name / "objective.json").read_text(),
            (evals / name / "cylinder_lift/rep0/simulation.json").read_text(),
        ) == records, name
    state = json.loads((tmp_path / "results/crash/optimizer.json").read_text())
    assert [r["id"] for r in state["records"]] == list(range(14))
    assert all(r["status"] in ("ok", "terminated") for r in state["records"])


@pytest.mark.slow
def test_failures_are_retried_up_to_the_cap_with_reasons(tmp_path):
    failures = [
        {
            "when": {"sliding_friction_pp": [0.7, 0.9]},
            "mode": "always",
            "reason": "particles escaped",
        },
        {"when": {"sliding_friction_pp": [0.1, 0.3]}, "mode": "once", "reason": "node lost"},
    ]
    config = study(
        tmp_path,
        "fail",
        engine={"failures": failures},
        optimizer={"max_evaluations": 10, "early_termination": {"enabled": False}},
    )
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "fail")
    # evaluations.csv rounds to 7 digits: leave out points within that of the windows' edges
    always = table[table["sliding_friction_pp"] > 0.7 + 1e-6]
    once = table[table["sliding_friction_pp"] < 0.3 - 1e-6]
    assert len(always) and len(once)
    assert set(always["status"]) == {"failed"} and set(always["attempts"]) == {2}
    assert all("particles escaped" in reason for reason in always["reason"])
    assert set(once["status"]) == {"ok"} and set(once["attempts"]) == {2}
    for name in once["evaluation"]:
        params = json.loads((tmp_path / f"results/fail/evals/{name}/params.json").read_text())
        assert params["previous_failures"] == ["cylinder_lift rep0: node lost"]


@pytest.mark.slow
def test_early_termination_stops_hopeless_runs_and_saves_time(tmp_path):
    duration = 4.0
    config = study(
        tmp_path,
        "et",
        engine={"duration": duration, "chunks": 40},
        optimizer={
            "max_evaluations": 12,
            "early_termination": {"thresholds": [1.0], "progress_boundaries": []},
        },
    )
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "et")
    stopped = table[table["status"] == "terminated"]
    assert len(stopped) >= 1
    state = json.loads((tmp_path / "results/et/optimizer.json").read_text())
    assert {r["id"] for r in state["records"] if r["status"] == "terminated"} == {
        int(name[1:]) for name in stopped["evaluation"]
    }
    for record in state["records"]:  # what a stopped run reported reaches the optimizer
        if record["status"] == "terminated":
            assert set(record["responses"]) == {
                "cylinder_lift.angle_of_repose",
                "cylinder_lift.bulk_density",
            }
            assert all(entry["final"] and entry["values"] for entry in record["responses"].values())
    walls = []
    for name in stopped["evaluation"]:
        sim = json.loads(
            (tmp_path / f"results/et/evals/{name}/cylinder_lift/rep0/simulation.json").read_text()
        )
        assert sim["status"] == "terminated"
        walls.append(sim["cost"]["wall_s"])
    # a run can be stopped late when a better evaluation finishes late (the bar drops)
    assert max(walls) < duration and min(walls) < duration * 0.9
    initial = state["initial_size"]
    assert all(int(name[1:]) >= initial for name in stopped["evaluation"])
    # stopped runs teach the response models: no region is proposed and stopped again and again
    consecutive = [
        len(list(run))
        for status, run in itertools.groupby(table["status"])
        if status == "terminated"
    ]
    assert max(consecutive) <= 3, table["status"].tolist()
    # the estimates and limits over time are kept; every stopped run has the row that stopped it
    trace = pd.read_csv(tmp_path / "results/et/early_termination.csv")
    stopping = trace[trace["stop"] == 1]
    assert set(stopped["evaluation"]) <= set(stopping["evaluation"])
    assert (stopping["judged"] > stopping["limit"]).all()
    # no limit in the initial design and in a run's last stretch
    held = trace[(trace["stop"] == 0) & trace["limit"].notna()]
    assert len(held) and (held["judged"] <= held["limit"]).all()
    assert (
        trace.loc[trace["evaluation"].map(lambda e: int(e[1:])) < state["initial_size"], "limit"]
        .isna()
        .all()
    )
    # the live view of the (now ended) study: state, both figures, and it says it is not running
    watched = finish(demcal(tmp_path, "watch", "et", "--every", "1"))
    assert "is not running (ended: evaluation budget reached" in watched
    page = (tmp_path / "results/et/live.html").read_text()
    assert 'http-equiv="refresh"' in page and page.count("data:image/png;base64,") == 2


@pytest.mark.slow
def test_second_daemon_on_the_same_study_is_refused(tmp_path):
    config = study(tmp_path, "twice", engine={"duration": 3.0})
    first = demcal(tmp_path, "run", config)
    time.sleep(3)
    second = demcal(tmp_path, "run", config)
    _, err = second.communicate(timeout=60)
    assert second.returncode == 2 and "another demcal daemon is running" in err
    stop = demcal(tmp_path, "stop", config)
    finish(stop)
    out = finish(first)
    assert "stopped on request" in out


@pytest.mark.slow
def test_bad_config_is_one_message(tmp_path):
    config = study(tmp_path, "bad", optimizer={"strategy": "guess"})
    proc = demcal(tmp_path, "run", config)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert err.strip() == (
        "demcal: optimizer.strategy: 'guess' is not one of dycors, "
        "kriging_ei, response_ei, solution_map, rackl_hanley"
    )
    proc = demcal(tmp_path, "run", study(tmp_path, "good"), "--workers", "-1")
    _, err = proc.communicate(timeout=60)
    assert (proc.returncode, err.strip()) == (
        2,
        "demcal: --workers -1: give at least 1 (evaluations in flight)",
    )
    for every in ("nan", "inf", "0"):
        proc = demcal(tmp_path, "watch", study(tmp_path, "good"), "--every", every)
        _, err = proc.communicate(timeout=60)
        assert (proc.returncode, err.strip()) == (
            2,
            f"demcal: --every {float(every)}: give 1 to 3600 s between updates",
        )


@pytest.mark.slow
def test_resume_with_a_changed_study_is_refused_but_budget_may_grow(tmp_path):
    config = study(tmp_path, "grow", optimizer={"max_evaluations": 4})
    finish(demcal(tmp_path, "run", config))
    assert len(evaluations(tmp_path, "grow")) == 4
    config = study(tmp_path, "grow", optimizer={"max_evaluations": 6})
    out = finish(demcal(tmp_path, "run", config))
    assert len(evaluations(tmp_path, "grow")) == 6 and "(6 of 6)" in out
    changed = yaml.safe_load(config.read_text())
    changed["engine"]["noise"] = 0.01
    config.write_text(yaml.safe_dump(changed))
    proc = demcal(tmp_path, "run", config)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert "holds a calibration of a different study (engine.noise: 0.0 -> 0.01)" in err


@pytest.mark.slow
def test_new_target_values_rescore_stored_simulations_without_simulating(tmp_path):
    """Corrected targets on resume: every objective is recomputed from the stored responses."""
    config = study(tmp_path, "rescore", optimizer={"max_evaluations": 5})
    finish(demcal(tmp_path, "run", config))
    evals = tmp_path / "results/rescore/evals"
    simulations = {p: p.read_text() for p in evals.glob("*/cylinder_lift/rep0/simulation.json")}
    changed = yaml.safe_load(config.read_text())
    changed["targets"][0]["value"] *= 1.1
    changed["targets"][1]["weight"] = 3.0
    config.write_text(yaml.safe_dump(changed))
    finish(demcal(tmp_path, "run", config))
    assert {p: p.read_text() for p in simulations} == simulations  # nothing simulated again
    table = evaluations(tmp_path, "rescore")
    assert len(table) == 5
    first, second = changed["targets"]
    records = [
        json.loads((evals / name / "rescored.json").read_text()) for name in table["evaluation"]
    ]
    rescored_with = load_frozen(tmp_path / "results/rescore/study.json").objective.version
    assert {r["scored_with"] for r in records} == {rescored_with}
    originals = [
        json.loads((evals / n / "objective.json").read_text()) for n in table["evaluation"]
    ]
    assert rescored_with not in {r["scored_with"] for r in originals}  # each job's record stays
    assert [r["replicates"] for r in records] == [r["replicates"] for r in originals]
    responses = pd.DataFrame([r["responses"] for r in records])  # every digit (the CSV keeps 7)
    expected = (
        (responses[f"cylinder_lift.{first['response']}"] - first["value"]) / first["value"]
    ) ** 2 + 3.0 * (
        (responses[f"cylinder_lift.{second['response']}"] - second["value"]) / second["value"]
    ) ** 2
    assert np.allclose([r["objective"] for r in records], expected, rtol=1e-9)
    assert np.allclose(table["objective"], expected, rtol=1e-6)
    state = json.loads((tmp_path / "results/rescore/optimizer.json").read_text())
    assert state["best_observed"] == pytest.approx(expected.min())
    # another response: not a re-score
    changed["targets"][1].update(response="angle_of_repose", value=30.0, unit="deg")
    changed["targets"] = changed["targets"][1:]
    config.write_text(yaml.safe_dump(changed))
    proc = demcal(tmp_path, "run", config)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "holds a calibration of a different study (targets: [" in err


@pytest.mark.slow
def test_rerun_failed_reruns_them_with_new_seeds(tmp_path):
    failures = [
        {"when": {"sliding_friction_pp": [0.1, 0.3]}, "mode": "once", "reason": "node lost"}
    ]
    config = study(
        tmp_path,
        "again",
        engine={"failures": failures},
        optimizer={"max_evaluations": 5, "early_termination": {"enabled": False}},
        calibration={"retries": 0},
    )
    finish(demcal(tmp_path, "run", config))
    failed = set(evaluations(tmp_path, "again").query("status == 'failed'")["evaluation"])
    assert failed
    out = finish(demcal(tmp_path, "rerun-failed", config))
    assert f"{len(failed)} failed evaluations" in out
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "again")
    assert len(table) == 5 and set(table["status"]) == {"ok"}
    assert set(table[table["attempts"] == 2]["evaluation"]) == failed


def snakemake_calibration(tmp_path, config):
    """The README's command: snakemake with the local profile on a study file."""
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "snakemake",
            "-s",
            ROOT / "Snakefile",
            "--profile",
            ROOT / "profiles" / "local",
            f"--configfile={config}",
        ],
        cwd=tmp_path,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_for_objectives(evals, count, proc=None, timeout=120):
    deadline = time.monotonic() + timeout
    while len(list(evals.glob("*/objective.json"))) < count:
        assert time.monotonic() < deadline, "evaluations did not finish"
        assert proc is None or proc.poll() is None, proc.communicate()
        time.sleep(0.2)


@pytest.mark.slow
def test_killed_snakemake_leaves_no_orphan_and_no_lock_the_same_command_finishes(tmp_path):
    """kill -9 of the top Snakemake: its daemon ends, no lock is left, a rerun
    resumes to the end."""
    config = study(tmp_path, "orphan")
    results = tmp_path / "results" / "orphan"
    top = snakemake_calibration(tmp_path, config)
    wait_for_objectives(results / "evals", 3, top)
    os.kill(top.pid, signal.SIGKILL)
    top.wait()
    done_before = {p.parent.name: p.read_text() for p in results.glob("evals/*/objective.json")}
    assert not (results / "finished.json").exists()  # the calibration has not ended
    rerun = snakemake_calibration(tmp_path, config)  # at once: the old daemon may still be ending
    out, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err[-3000:]
    finished = json.loads((results / "finished.json").read_text())
    assert finished["reason"] == "evaluation budget reached (14 of 14)"
    table = evaluations(tmp_path, "orphan")
    assert sorted(table["evaluation"]) == [f"e{i:04d}" for i in range(14)]
    assert set(table["status"]) <= {"ok", "terminated"}
    for name, record in done_before.items():
        assert (results / "evals" / name / "objective.json").read_text() == record, name
    assert (results / "report.html").exists()


@pytest.mark.slow
def test_a_daemon_that_dies_on_a_disk_error_leaves_the_calibration_unfinished(
    tmp_path, monkeypatch
):
    """Results folder unwritable mid-run (EROFS), then repaired: the same command resumes."""
    from demcal.daemon import loop as daemon
    from demcal.study.config import load_study_file
    from demcal.study.model import freeze

    monkeypatch.chdir(tmp_path)
    config = study(tmp_path, "rofs")
    writes = []

    def read_only_after_three(*args):
        writes.append(args)
        if len(writes) > 3:
            raise OSError(errno.EROFS, "Read-only file system")
        original(*args)

    original = daemon.write_evaluations_csv
    monkeypatch.setattr(daemon, "write_evaluations_csv", read_only_after_three)
    calibration = daemon.Calibration(freeze(load_study_file(config)), None, workers=2)
    with pytest.raises(OSError, match="Read-only"):
        calibration.run(show_progress=lambda line: None)
    assert not (tmp_path / "results/rofs/finished.json").exists()
    monkeypatch.setattr(daemon, "write_evaluations_csv", original)
    out = finish(demcal(tmp_path, "run", config))
    assert "evaluation budget reached (14 of 14)" in out
    assert len(evaluations(tmp_path, "rofs")) == 14
    assert (tmp_path / "results/rofs/finished.json").exists()


@pytest.mark.slow
def test_editing_the_study_file_during_a_run_does_not_reach_the_running_calibration(tmp_path):
    """Jobs read the frozen results/<study>/study.json, never the YAML."""
    config = study(
        tmp_path,
        "frozen",
        optimizer={"max_evaluations": 8, "early_termination": {"enabled": False}},
    )
    original = yaml.safe_load(config.read_text())
    proc = demcal(tmp_path, "run", config)
    results = tmp_path / "results" / "frozen"
    wait_for_objectives(results / "evals", 2, proc)
    frozen = (results / "study.json").read_text()
    edited = yaml.safe_load(config.read_text())
    edited["targets"][0]["value"] *= 2.0
    edited["engine"]["noise"] = 0.2
    config.write_text(yaml.safe_dump(edited))
    finish(proc)
    assert (results / "study.json").read_text() == frozen
    wanted = {f"{t['scene']}.{t['response']}": t["value"] for t in original["targets"]}
    scored_with = load_frozen(results / "study.json")
    assert {t.key: t.value for t in scored_with.targets} == wanted
    objectives = sorted(results.glob("evals/*/objective.json"))
    assert len(objectives) == 8 and not list(results.glob("evals/*/rescored.json"))
    for path in objectives:
        assert json.loads(path.read_text())["scored_with"] == scored_with.objective.version, path


def test_a_failure_after_demcal_stop_is_recorded_not_retried(tmp_path, monkeypatch):
    """The retry used to remove the evaluation's STOP file and relaunch it after the stop."""
    from demcal.daemon.loop import Calibration
    from demcal.results.layout import evaluation_id
    from demcal.results.records import ObjectiveRecord, PointRecord, Status
    from demcal.study.config import load_study_file
    from demcal.study.model import freeze

    monkeypatch.chdir(tmp_path)
    calibration = Calibration(freeze(load_study_file(study(tmp_path, "halt"))), None, 2)
    launched = []
    monkeypatch.setattr(calibration, "launch", launched.append)
    failed = ObjectiveRecord("e0000", Status.FAILED, "cylinder_lift rep0: node lost")
    for proposal in calibration.optimizer.ask(2):
        evaluation = evaluation_id(proposal.id)
        PointRecord(dict(zip(calibration.names, proposal.x))).write(
            calibration.files.evaluation(evaluation).params
        )
    calibration.finish("e0000", failed)
    assert launched == ["e0000"]  # retried while the calibration runs (retries: 1)
    calibration.files.stop_calibration.touch()  # demcal stop
    calibration.finish("e0001", failed)
    assert launched == ["e0000"]
    assert [r.status for r in calibration.optimizer.records] == ["pending", "failed"]


@pytest.mark.slow
def test_status_and_stop_say_what_runs_and_what_stop_means(tmp_path):
    config = study(tmp_path, "halting", engine={"duration": 3.0})
    daemon = demcal(tmp_path, "run", config)
    deadline = time.monotonic() + 60
    while not list((tmp_path / "results/halting/evals").glob("e*/launch.json")):
        assert time.monotonic() < deadline and daemon.poll() is None
        time.sleep(0.2)
    status = finish(demcal(tmp_path, "status", "halting"))  # by name, not by file
    assert (
        f"study 'halting': running (daemon pid {daemon.pid})" in status
        and " running (budget 14)" in status
    )
    stop = finish(demcal(tmp_path, "stop", config))
    assert (
        "asked the daemon of 'halting'" in stop and "'demcal run' continues the calibration" in stop
    )
    assert "finished: stopped on request (demcal stop)" in finish(daemon)
    status = finish(demcal(tmp_path, "status", "halting"))
    assert (
        "study 'halting': ended: stopped on request (demcal stop)" in status
        and "pending" not in status
    )
    assert "nothing to stop" in finish(demcal(tmp_path, "stop", "halting"))
    listing = finish(demcal(tmp_path, "studies"))
    assert listing.startswith("halting: ended: stopped on request (demcal stop)\n  ")


@pytest.mark.slow
def test_a_point_added_by_hand_is_evaluated_by_the_next_run_and_joins_the_data(tmp_path):
    config = study(tmp_path, "byhand", optimizer={"max_evaluations": 6})
    finish(demcal(tmp_path, "run", config))
    proc = demcal(
        tmp_path, "add-point", "byhand", "sliding_friction_pp=0.95", "rolling_friction_pp=0.1"
    )
    _, err = proc.communicate(timeout=60)
    assert (
        proc.returncode == 2 and "sliding_friction_pp=0.95 is outside its bounds [0.1, 0.9]" in err
    )
    out = finish(
        demcal(
            tmp_path, "add-point", "byhand", "sliding_friction_pp=0.4", "rolling_friction_pp=0.1"
        )
    )
    assert "point e0006 added to study 'byhand'" in out
    assert not (tmp_path / "results/byhand/finished.json").exists()
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "byhand")
    row = table[table["evaluation"] == "e0006"].iloc[0]
    assert len(table) == 7 and row["status"] == "ok"
    assert (row["sliding_friction_pp"], row["rolling_friction_pp"]) == pytest.approx((0.4, 0.1))
    state = json.loads((tmp_path / "results/byhand/optimizer.json").read_text())
    assert state["records"][6]["by_hand"] and state["records"][6]["responses"]
