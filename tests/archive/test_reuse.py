"""``reuse: archive`` on the analytic engine, in-process (issue 21, item 2).

A first study calibrates to targets at one truth and records its simulations in the
archive; a second study of the same material (same scene, engine, settings and fixed
values) with targets at another truth starts from them. Measured with the settings below:
the second study's first new simulation already meets both targets within their spreads,
while the same study from scratch needs 11 simulations for that.
"""

from __future__ import annotations

import json

import pandas as pd
import pytest
from helpers import run_calibration, true_targets

from demcal.cli.inspect import study_state
from demcal.cli.run import print_best
from demcal.daemon.loop import Calibration
from demcal.errors import ConfigError
from demcal.optimizer.responses import final_means
from demcal.reporting.headline import report_headline
from demcal.results.records import ObjectiveRecord, ReusedRecord, SimulationRecord
from demcal.study.config import load_study
from demcal.study.model import freeze


def targets(sliding: float, rolling: float) -> list[dict]:
    """The closed form's responses at a truth, with spreads (0.5°, 8 kg/m³)."""
    spreads = {"angle_of_repose": 0.5, "bulk_density": 8.0}
    truth = {"sliding_friction_pp": sliding, "rolling_friction_pp": rolling}
    return [{**t, "spread": spreads[t["response"]]} for t in true_targets(truth)]


FIRST_TRUTH, SECOND_TRUTH = (0.4, 0.1), (0.5, 0.13)


def config(name: str, truth: tuple[float, float], budget: int = 12, **changes) -> dict:
    return {
        "study": name,
        "engine": {"name": "analytic", "noise": 0.002},
        "parameters": {
            "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
            "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
        },
        "fixed": {"restitution_pp": 0.5},
        "targets": targets(*truth),
        "replicates": 1,
        "seed": 3,
        "optimizer": {
            "max_evaluations": budget,
            "early_termination": {"enabled": False},
            "response_model": "cubic_rbf",
        },
        "calibration": {"poll_seconds": 0.001, "retries": 1},
        **changes,
    }


def new_until_within_spreads(calibration: Calibration) -> int | None:
    """How many new simulations ran until one met every target within its spread."""
    table = pd.read_csv(calibration.files.evaluations_csv)
    new = table[table["origin"] == "new"].reset_index(drop=True)
    for index, row in new.iterrows():
        if all(abs(row[t.key] - t.value) <= t.spread for t in calibration.study.targets):
            return int(index) + 1
    return None


@pytest.fixture
def first(tmp_path, monkeypatch) -> Calibration:
    """The first study, run in ``tmp_path`` (its simulations are in results/archive.sqlite)."""
    monkeypatch.chdir(tmp_path)
    return run_calibration(config("first", FIRST_TRUTH, budget=15))


def test_new_targets_cost_a_few_new_simulations_with_reuse(first):
    reused = run_calibration(config("second", SECOND_TRUTH, reuse="archive"))
    scratch = run_calibration(config("scratch", SECOND_TRUTH))
    assert reused.optimizer.reused_points == first.optimizer.completed_evaluations() == 10
    assert new_until_within_spreads(reused) <= 3  # measured: 1
    assert new_until_within_spreads(scratch) >= 6  # measured: 11
    assert reused.optimizer.completed_evaluations() < scratch.optimizer.completed_evaluations()

    table = pd.read_csv(reused.files.evaluations_csv)
    new = reused.optimizer.completed_evaluations()
    assert table["origin"].value_counts().to_dict() == {"archive": 10, "new": new}
    assert set(table.loc[table["origin"] == "archive", "evaluation"]) == {
        f"first/e{i:04d}" for i in range(10)
    }
    row = table.set_index("evaluation").loc["first/e0000"]
    old = ObjectiveRecord.read(first.files.evaluation("e0000").objective)
    assert row["objective"] == pytest.approx(
        reused.study.objective.of_means(old.responses), rel=1e-6
    )
    assert row["objective"] != pytest.approx(old.objective, rel=1e-3)  # not the first's
    best = json.loads(reused.files.best.read_text())
    assert best["evaluations"] == {"new": new, "reused": 10}
    assert "reused" not in json.loads(first.files.best.read_text())
    assert "evaluations" not in json.loads(first.files.best.read_text())
    assert (
        f"**Evaluations:** {new} new ({new} ok, 0 failed, 0 stopped early) and 10 points "
        "reused from the archive" in report_headline(reused.study)
    )
    assert "reused" not in report_headline(scratch.study)


def test_a_reused_point_is_scored_by_the_new_study_and_may_be_the_answer(first, capsys):
    """With the first study's targets again, its own best point answers, named by its source,
    and new simulations confirm it."""
    confirmed = config("again", FIRST_TRUTH, reuse="archive")
    confirmed["optimizer"]["confirm_replicates"] = 2
    again = run_calibration(confirmed)
    best = json.loads(again.files.best.read_text())
    assert best["reused"] is True and best["evaluation"].startswith("first/")
    assert best["confirmation"]["of"] == best["evaluation"]
    assert len(best["confirmation"]["evaluations"]) == 2
    for name in best["confirmation"]["evaluations"]:
        point = json.loads(again.files.evaluation(name).params.read_text())
        assert point["proposed_by"] == f"confirmation of {best['evaluation']}"
    table = pd.read_csv(again.files.evaluations_csv).set_index("evaluation")
    assert best["objective"] == pytest.approx(table.loc[best["evaluation"], "objective"])
    assert "reused from the archive" in report_headline(again.study)
    source = ObjectiveRecord.read(first.files.evaluation(best["evaluation"][6:]).objective)
    assert best["objective"] == pytest.approx(source.objective, rel=1e-12)
    print_best(again.study)
    assert f": simulated by {best['evaluation']} on the same simulator" in capsys.readouterr().out
    again.files.reused.unlink()
    print_best(again.study)
    assert "no longer holds it: run the study again" in capsys.readouterr().out


@pytest.mark.parametrize(
    "changes",
    [
        {"fixed": {"restitution_pp": 0.6}},
        {"scenes": {"cylinder_lift": {"settings": {"lift_speed": 0.02}}}},
        {"timestep_fraction": 0.1},
        {"engine": {"name": "analytic", "noise": 0.01}},
    ],
    ids=["fixed", "settings", "timestep", "engine_settings"],
)
def test_other_fixed_values_or_settings_reuse_nothing(first, changes):
    other = run_calibration(config("other", SECOND_TRUTH, budget=6, reuse="archive", **changes))
    assert other.optimizer.reused_points == 0
    assert ReusedRecord.read(other.files.reused).points == []
    assert json.loads(other.files.best.read_text())["evaluations"] == {"new": 6, "reused": 0}


def test_a_resumed_study_does_not_reuse_twice(first):
    short = run_calibration(config("second", SECOND_TRUTH, budget=2, reuse="archive"))
    assert (short.optimizer.reused_points, short.optimizer.completed_evaluations()) == (10, 2)
    reused_file = short.files.reused.read_text()
    corrected = config("second", SECOND_TRUTH, budget=4, reuse="archive")
    corrected["targets"][0]["value"] += 1.0  # corrected targets re-score the reused points too
    resumed = run_calibration(corrected)
    assert resumed.optimizer.reused_points == 10
    assert resumed.optimizer.completed_evaluations() > 2
    assert resumed.files.reused.read_text() == reused_file
    assert len(resumed.optimizer.records) == 10 + resumed.optimizer.completed_evaluations()
    for record in resumed.optimizer.records[:10]:
        means = {key: entry.mean for key, entry in record.responses.items()}
        assert record.value == pytest.approx(resumed.study.objective.of_means(means), rel=1e-12)


def test_new_seeds_never_repeat_reused_ones(first):
    """Narrower bounds reuse fewer points than the first study ran, so new evaluations get
    names the first study used (same study seed): their plain seeds would repeat."""
    narrow = config("narrow", SECOND_TRUTH, budget=8, reuse="archive")
    narrow["parameters"]["sliding_friction_pp"] = {"lower": 0.3, "upper": 0.9}
    calibration = run_calibration(narrow)
    reused = ReusedRecord.read(calibration.files.reused)
    assert 0 < len(reused.points) < 10
    new = [
        SimulationRecord.read(files.replicate("cylinder_lift", 0).simulation)
        for files in calibration.files.evaluations()
    ]
    reused_seeds = {s["evaluation"]: s["seed"] for p in reused.points for s in p["simulations"]}
    repeated = [
        sim
        for sim in new
        if calibration.study.simulation_seed(sim.evaluation, "cylinder_lift", 0)
        == reused_seeds.get(sim.evaluation)
    ]
    assert repeated, "no new evaluation would have repeated a reused seed: the test shows nothing"
    assert not {sim.seed for sim in new} & reused.seeds


def test_seeds_move_on_only_past_those_to_avoid(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = load_study(config("s", SECOND_TRUTH))
    plain = study.simulation_seed("e0001", "cylinder_lift", 0)
    assert study.simulation_seed("e0001", "cylinder_lift", 0, avoid={plain + 1}) == plain
    moved = study.simulation_seed("e0001", "cylinder_lift", 0, avoid={plain})
    assert moved != plain
    assert study.simulation_seed("e0001", "cylinder_lift", 0, avoid={plain, moved}) not in {
        plain,
        moved,
    }


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"reuse": "yes"}, "reuse: 'yes' is not one of archive, neighbours, False"),
        ({"reuse": "archive", "archive": False}, "reuse: 'archive' reads the study's archive"),
    ],
)
def test_bad_reuse_is_refused_naming_the_field(changes, message):
    with pytest.raises(ConfigError, match=message.replace("(", r"\(")):
        load_study(config("bad", SECOND_TRUTH, **changes))


def test_reuse_is_frozen_with_the_study(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(config("frozen", SECOND_TRUTH, reuse="archive")))
    assert study.reuse == "archive"
    assert json.loads(study.files.study.read_text())["reuse"] == "archive"
    with pytest.raises(ConfigError, match="reuse: 'archive' -> None"):
        freeze(load_study(config("frozen", SECOND_TRUTH)))
    plain = freeze(load_study(config("plain", SECOND_TRUTH)))
    assert plain.reuse is None and "reuse" not in json.loads(plain.files.study.read_text())


def test_status_counts_the_reused_points_apart(first):
    second = run_calibration(config("second", SECOND_TRUTH, reuse="archive"))
    _, counts = study_state(second.study)
    new = second.optimizer.completed_evaluations()
    assert counts == f"{new} ok (budget 12); 10 points reused from the archive"


def test_a_study_run_again_under_another_name_is_reused_once(first):
    """The same points with the same seeds under another study name are the same
    simulations: the archive keeps both records, reuse counts each run once."""
    run_calibration(config("first-again", FIRST_TRUTH, budget=4))
    second = run_calibration(config("second", SECOND_TRUTH, budget=1, reuse="archive"))
    points = ReusedRecord.read(second.files.reused).points
    first_ok = pd.read_csv(first.files.evaluations_csv).query("status == 'ok'")
    assert len(points) == len(first_ok)  # the first study's points, none twice
    assert all(len(values) == 1 for p in points for values in p["replicates"].values())


def test_a_joint_study_takes_the_first_tests_runs_as_data_of_their_models_only(first):
    """A second test added to the first (demcal advise's joint study): the archive holds the
    first test alone, so each of its points teaches the models of its responses and is no
    answer, no best value and no point of the budget (a partial point, like a run stopped
    early)."""
    joint = config("joint", FIRST_TRUTH, budget=4, reuse="archive")
    joint["targets"].append(
        {"scene": "shear_box", "response": "shear_angle", "value": 25.0, "spread": 1.0}
    )
    calibration = run_calibration(joint)
    reused = ReusedRecord.read(calibration.files.reused)
    assert len(reused.points) == first.optimizer.completed_evaluations() == 10
    assert all(
        p["partial"]
        and set(p["replicates"]) == {"cylinder_lift.angle_of_repose", "cylinder_lift.bulk_density"}
        for p in reused.points
    )
    taken = [r for r in calibration.optimizer.records if r.reused_from]
    assert len(taken) == 10 and all(r.status == "terminated" and r.value is None for r in taken)
    assert calibration.optimizer.completed_evaluations() == 4  # the budget: new runs only
    best = calibration.optimizer.best()
    assert best is not None and best.reused_from is None
    # the angle's model learns from the first test's 10 points and the 4 new ones
    x, _ = final_means(calibration.optimizer.records, "cylinder_lift.angle_of_repose", 2)
    assert len(x) == 14
    table = pd.read_csv(calibration.files.evaluations_csv)
    assert (table["status"] == "terminated").sum() == 10
