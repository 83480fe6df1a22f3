"""Objectives beyond matching a value (issue 24, item 2): bounds (at_least, at_most), goals
(minimise, maximise), and a design study of the transfer chute's stand-in that meets them."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from helpers import ROOT, calibrate

from demcal.errors import ConfigError
from demcal.optimizer.membership import membership_probability
from demcal.optimizer.objective import ResponseObjective, Target, relative_miss, target_error
from demcal.results.records import BestRecord
from demcal.study.config import load_study
from demcal.study.model import study_from_record, study_record

CHUTE = {
    "study": "chute-design",
    "engine": {"name": "analytic", "noise": 0.0},
    "parameters": {
        "funnel_y": {"lower": -0.4, "upper": 0.4},
        "belt_speed": {"lower": 3.0, "upper": 4.0},
    },
    "targets": [
        {"scene": "transfer_chute", "response": "split", "at_least": 0.45, "at_most": 0.55}
    ],
    "optimizer": {"max_evaluations": 14, "early_termination": {"enabled": False}},
    "calibration": {"poll_seconds": 0.001, "retries": 1},
    "seed": 2,
}


def chute(*targets, **changes) -> dict:
    config = copy.deepcopy(CHUTE)
    if targets:
        config["targets"] = [{"scene": "transfer_chute", **t} for t in targets]
    return {**config, **changes}


# -- the objective's arithmetic ----------------------------------------------------
def test_inside_the_bounds_there_is_no_error_outside_the_error_is_to_the_bound_passed():
    band = Target("s", "r", 0.45, lower=0.45, upper=0.55)
    errors = target_error(band, np.array([0.3, 0.45, 0.5, 0.55, 0.66]))
    assert errors == pytest.approx([(0.3 - 0.45) / 0.45, 0.0, 0.0, 0.0, (0.66 - 0.55) / 0.55])
    at_least = Target("s", "r", 50.0, lower=50.0, spread=2.0)
    assert target_error(at_least, 46.0, "precision") == pytest.approx(-2.0)
    assert target_error(at_least, 80.0, "precision") == pytest.approx(0.0)
    at_most_zero = Target("s", "r", 0.0, upper=0.0)  # a minimised share: the absolute miss
    assert target_error(at_most_zero, 0.2) == pytest.approx(0.2)
    assert relative_miss(band, 0.5) == 0.0 and relative_miss(band, 0.66) == pytest.approx(0.2)


def test_a_target_without_bounds_keeps_its_record_and_fingerprint_as_before():
    plain = ResponseObjective((Target("s", "r", 2.0, 1.0, 0.1),))
    assert plain.to_dict()["targets"][0] == {
        "scene": "s",
        "response": "r",
        "value": 2.0,
        "weight": 1.0,
        "spread": 0.1,
    }
    bounded = ResponseObjective((Target("s", "r", 2.0, 1.0, 0.1, lower=2.0),))
    assert ResponseObjective.from_dict(bounded.to_dict()) == bounded
    assert bounded.version != plain.version


def test_membership_of_a_band_is_the_probability_of_lying_within_it():
    band = Target("s", "r", 0.45, lower=0.45, upper=0.55, spread=0.0)
    means = {"s.r": np.array([0.5, 0.8])}
    stds = {"s.r": np.array([0.001, 0.001])}
    p = membership_probability((band,), means, stds, {"s.r": 0.0}, 2.0)
    assert p[0] == pytest.approx(1.0) and p[1] == pytest.approx(0.0)


# -- the study file -------------------------------------------------------------------
def test_bounds_and_goals_become_targets_with_bounds():
    study = load_study(
        chute(
            {"response": "split", "at_least": 0.45, "at_most": 0.55},
            {"response": "mass_flow_right", "goal": "minimise"},
            {"response": "mass_flow_left", "at_least": 20.0},
        )
    )
    split, right, left = study.targets
    assert (split.lower, split.upper, split.value) == (0.45, 0.55, 0.45)
    assert (right.lower, right.upper) == (None, 0.0)
    assert (left.lower, left.upper) == (20.0, None)
    assert study_from_record(study_record(study)).targets == study.targets


@pytest.mark.parametrize(
    "target, message",
    [
        (
            {"response": "split", "value": 0.5, "at_least": 0.4},
            r"targets\[0\]: give one of a value .* not value and bounds",
        ),
        (
            {"response": "split", "at_least": 0.6, "at_most": 0.5},
            r"targets\[0\].at_most: 0.5 - is not above at_least \(0.6 -\)",
        ),
        (
            {"response": "split", "at_most": 1.5},
            r"targets\[0\].at_most: 1.5 - is not a possible split; it lies in \[0, 1\] -",
        ),
        (
            {"response": "flow_difference", "goal": "minimise"},
            r"targets\[0\].goal: flow_difference has no lowest possible value to minimise",
        ),
        (
            {"response": "mass_flow_left", "goal": "maximise"},
            r"targets\[0\].goal: mass_flow_left has no highest possible value to maximise",
        ),
        ({"response": "split", "goal": "balance"}, r"targets\[0\].goal: 'balance' is not one of"),
    ],
)
def test_a_bad_bound_or_goal_is_refused_by_name(target, message):
    with pytest.raises(ConfigError, match=message):
        load_study(chute(target))


#: Each goal on the transfer chute's responses: the bounds it becomes, or None where the
#: response has no lowest or highest value in the goal's direction (refused).
GOALS = [
    ("mass_flow_left", "minimise", (None, 0.0)),  # a spillage, a leak: towards 0 kg/s
    ("mass_flow_left", "maximise", None),  # a mass flow has no highest value
    ("flow_difference", "minimise", None),  # left minus right, of either sign
    ("flow_difference", "maximise", None),
    ("split", "minimise", (None, 0.0)),
    ("split", "maximise", (1.0, None)),
]


@pytest.mark.parametrize("response, goal, bounds", GOALS)
def test_a_goal_is_the_responses_own_bound_in_its_direction(response, goal, bounds):
    target = {"response": response, "goal": goal}
    if bounds is None:
        lowest = "lowest" if goal == "minimise" else "highest"
        with pytest.raises(ConfigError, match=rf"{response} has no {lowest} possible value"):
            load_study(chute(target))
    else:
        (made,) = load_study(chute(target)).targets
        assert (made.lower, made.upper) == bounds


def test_docs_studies_md_says_which_goals_are_refused_as_the_code_does():
    text = " ".join((ROOT / "docs" / "studies.md").read_text().split())
    section = text[text.index("### Bounds and goals") :]
    section = section[: section.index(" ## ")]
    assert "a mass flow towards 0" in section
    assert "maximising a mass flow (it has no highest value)" in section
    assert "either goal on a flow difference" in section


# -- a design study end to end (the analytic stand-in, in-process) ---------------------
@pytest.mark.parametrize("strategy", ["response_ei", "dycors"])
def test_a_design_study_finds_a_point_that_splits_within_the_bounds(
    tmp_path, monkeypatch, strategy
):
    monkeypatch.chdir(tmp_path)
    config = chute()
    config["optimizer"]["strategy"] = strategy
    calibration, runner, reason = calibrate(config)
    best = BestRecord.read(calibration.study.files.best)
    split = best.responses["transfer_chute.split"]
    assert 0.45 <= split <= 0.55, (reason, best.parameters, split)
    assert best.objective == pytest.approx(0.0, abs=1e-12)
    assert best.relative_errors["transfer_chute.split"] == 0.0


def test_a_miss_of_a_zero_target_is_shown_in_the_response_unit_not_in_per_cent():
    from demcal.reporting.terminal import error_text

    zero = Target("s", "r", 0.0, spread=2.8)
    assert error_text(zero, 1.99, relative_miss(zero, 1.99), "kg/s") == "+1.99 kg/s"
    band = Target("s", "r", 0.45, lower=0.45, upper=0.55)
    assert error_text(band, 0.66, relative_miss(band, 0.66), "-") == "+20.0%"
    assert error_text(band, None, None, "-") == "–"


def test_a_design_study_takes_its_material_from_a_calibration_end_to_end(tmp_path, monkeypatch):
    """Calibrate the analytic cylinder lift, then design the chute for its answer."""
    from helpers import ANALYTIC_STUDY

    monkeypatch.chdir(tmp_path)
    lab = copy.deepcopy(ANALYTIC_STUDY)
    lab.update(
        study="lab",
        optimizer={"max_evaluations": 8, "early_termination": {"enabled": False}},
        calibration={"poll_seconds": 0.001, "retries": 1},
    )
    calibration, _, _ = calibrate(lab)
    answer = BestRecord.read(calibration.study.files.best)
    design, _, _ = calibrate(chute(material="lab"))
    study = design.study
    assert study.material["study"] == "lab"
    assert study.material["evaluation"] == answer.evaluation
    for name, value in answer.parameters.items():
        assert study.fixed[name] == value
    assert study.fixed["restitution_pp"] == ANALYTIC_STUDY["fixed"]["restitution_pp"]
    split = BestRecord.read(study.files.best).responses["transfer_chute.split"]
    assert 0.45 <= split <= 0.55


def test_a_robust_design_study_simulates_each_replicate_with_its_drawn_material(
    tmp_path, monkeypatch
):
    """A calibration that left the wall friction loose; the design draws it per replicate
    and scores each evaluation by the loss over the draws."""
    from helpers import ANALYTIC_STUDY

    from demcal.results.records import ObjectiveRecord, SimulationRecord
    from demcal.study.model import freeze

    monkeypatch.chdir(tmp_path)
    lab = copy.deepcopy(ANALYTIC_STUDY)
    lab.update(study="lab", parameters={"sliding_friction_pw": {"lower": 0.1, "upper": 0.9}})
    calibration = freeze(load_study(lab))
    BestRecord("e0003", {"sliding_friction_pw": 0.5}, objective=0.01).write(calibration.files.best)
    rows = [f"{0.2 + 0.1 * i},0.9" for i in range(7)]
    calibration.files.solutions.write_text(
        "sliding_friction_pw,membership_probability\n" + "\n".join(rows) + "\n"
    )
    design, _, _ = calibrate(
        chute(
            material={"calibration": "lab", "robust": True},
            replicates=3,
            optimizer={"max_evaluations": 6, "early_termination": {"enabled": False}},
        )
    )
    study = design.study
    assert study.optimizer.strategy == "dycors" and len(study.material_draws) == 3
    objective = study.objective
    spread_counted = []
    for files in design.files.evaluations():
        record = ObjectiveRecord.read(files.objective)
        for replicate, draw in enumerate(study.material_draws):
            simulated = SimulationRecord.read(
                files.replicate("transfer_chute", replicate).simulation
            )
            assert simulated.parameters["sliding_friction_pw"] == draw["sliding_friction_pw"]
        each = objective.per_replicate(record.replicates)
        assert record.objective == pytest.approx(sum(each) / 3)
        spread_counted.append(record.objective - objective.of_means(record.responses))
    assert min(spread_counted) >= 0.0 and max(spread_counted) > 0.0  # the draws' spread counts
