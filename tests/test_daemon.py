"""The calibration daemon end to end on the analytic engine (child Snakemake per evaluation)."""

import json
import os
import signal
import time

import yaml

from conftest import ROOT, demcal, evaluations, finish, study

def test_local_calibration_reaches_the_known_optimum(tmp_path):
    """20 evaluations get the responses within about 3 % of the targets (objective 0 at TRUTH).

    The two responses pin the two parameters only along a shallow valley, so
    the found point is near the valley, not necessarily at TRUTH: the
    optimizer's own quality is measured in benchmarks/optimizer.
    """
    config = study(tmp_path, "conv", optimizer={"max_evaluations": 20,
                                                 "early_termination": {"enabled": False}})
    out = finish(demcal(tmp_path, "run", config, "--profile", ROOT / "profiles" / "local"))
    best = json.loads((tmp_path / "results/conv/best.json").read_text())
    table = evaluations(tmp_path, "conv")
    assert len(table) == 20 and set(table["status"]) == {"ok"}
    assert best["objective"] < 2e-3  # responses within about 3 % of the targets
    assert "evaluation budget reached (20 of 20)" in out
    assert "cylinder_lift.angle_of_repose [deg]" in out


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
    done_before = {p.parent.name: (p.read_text(), (p.parent / "cylinder_lift/rep0/simulation.json")
                                   .read_text()) for p in evals.glob("*/objective.json")}
    assert len(done_before) >= 4
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "crash")
    assert sorted(table["evaluation"]) == [f"e{i:04d}" for i in range(14)]
    assert set(table["status"]) <= {"ok", "terminated"}
    for name, records in done_before.items():
        assert ((evals / name / "objective.json").read_text(),
                (evals / name / "cylinder_lift/rep0/simulation.json").read_text()) == records, name
    state = json.loads((tmp_path / "results/crash/optimizer.json").read_text())
    assert [r["id"] for r in state["records"]] == list(range(14))
    assert all(r["status"] in ("ok", "terminated") for r in state["records"])


def test_failures_are_retried_up_to_the_cap_with_reasons(tmp_path):
    failures = [{"when": {"sliding_friction_pp": [0.7, 0.9]}, "mode": "always",
                 "reason": "particles escaped"},
                {"when": {"sliding_friction_pp": [0.1, 0.3]}, "mode": "once",
                 "reason": "node lost"}]
    config = study(tmp_path, "fail", engine={"failures": failures},
                   optimizer={"max_evaluations": 10, "early_termination": {"enabled": False}})
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "fail")
    always = table[table["sliding_friction_pp"] >= 0.7]
    once = table[table["sliding_friction_pp"] <= 0.3]
    assert len(always) and len(once)
    assert set(always["status"]) == {"failed"} and set(always["attempts"]) == {2}
    assert all("particles escaped" in reason for reason in always["reason"])
    assert set(once["status"]) == {"ok"} and set(once["attempts"]) == {2}
    for name in once["evaluation"]:
        params = json.loads((tmp_path / f"results/fail/evals/{name}/params.json").read_text())
        assert params["previous_failures"] == ["cylinder_lift rep0: node lost"]


def test_early_termination_stops_hopeless_runs_and_saves_time(tmp_path):
    duration = 4.0
    config = study(tmp_path, "et", engine={"duration": duration, "chunks": 40},
                   optimizer={"max_evaluations": 12,
                              "early_termination": {"thresholds": [1.0],
                                                    "progress_boundaries": []}})
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "et")
    stopped = table[table["status"] == "terminated"]
    assert len(stopped) >= 1
    state = json.loads((tmp_path / "results/et/optimizer.json").read_text())
    assert {r["id"] for r in state["records"] if r["status"] == "terminated"} == {
        int(name[1:]) for name in stopped["evaluation"]}
    for name in stopped["evaluation"]:
        sim = json.loads((tmp_path / f"results/et/evals/{name}/cylinder_lift/rep0/"
                                     "simulation.json").read_text())
        assert sim["status"] == "terminated"
        assert sim["cost"]["wall_s"] < duration * 0.9
    initial = state["initial_size"]
    assert all(int(name[1:]) >= initial for name in stopped["evaluation"])


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


def test_bad_config_is_one_message(tmp_path):
    config = study(tmp_path, "bad", optimizer={"strategy": "guess"})
    proc = demcal(tmp_path, "run", config)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert err.strip() == ("demcal: optimizer.strategy: 'guess' is not one of dycors, "
                           "kriging_ei")


def test_resume_with_a_changed_study_is_refused_but_budget_may_grow(tmp_path):
    config = study(tmp_path, "grow", optimizer={"max_evaluations": 4})
    finish(demcal(tmp_path, "run", config))
    assert len(evaluations(tmp_path, "grow")) == 4
    config = study(tmp_path, "grow", optimizer={"max_evaluations": 6})
    out = finish(demcal(tmp_path, "run", config))
    assert len(evaluations(tmp_path, "grow")) == 6 and "(6 of 6)" in out
    changed = yaml.safe_load(config.read_text())
    changed["targets"][0]["value"] *= 1.1
    config.write_text(yaml.safe_dump(changed))
    proc = demcal(tmp_path, "run", config)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2
    assert "different study definition (changed: targets)" in err


def test_rerun_failed_reruns_them_with_new_seeds(tmp_path):
    failures = [{"when": {"sliding_friction_pp": [0.1, 0.3]}, "mode": "once",
                 "reason": "node lost"}]
    config = study(tmp_path, "again", engine={"failures": failures},
                   optimizer={"max_evaluations": 5, "early_termination": {"enabled": False}},
                   calibration={"retries": 0})
    finish(demcal(tmp_path, "run", config))
    failed = set(evaluations(tmp_path, "again").query("status == 'failed'")["evaluation"])
    assert failed
    out = finish(demcal(tmp_path, "rerun-failed", config))
    assert f"{len(failed)} failed evaluations" in out
    finish(demcal(tmp_path, "run", config))
    table = evaluations(tmp_path, "again")
    assert len(table) == 5 and set(table["status"]) == {"ok"}
    assert set(table[table["attempts"] == 2]["evaluation"]) == failed
