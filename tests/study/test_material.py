"""A study's material from a finished calibration (issue 24, item 1): ``material:``."""

from __future__ import annotations

import copy
import json

import pytest
from helpers import ANALYTIC_STUDY

from demcal.errors import ConfigError
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.results.records import BestRecord
from demcal.study.config import load_study
from demcal.study.model import freeze, study_from_record, study_record

ANSWER = {"sliding_friction_pp": 0.42, "rolling_friction_pp": 0.11, "d50": 2.2e-3}


@pytest.fixture
def calibrated(tmp_path, monkeypatch):
    """results/lab/: a frozen calibration with d50 free, and its best.json."""
    monkeypatch.chdir(tmp_path)
    config = copy.deepcopy(ANALYTIC_STUDY)
    config["study"] = "lab"
    config["parameters"]["d50"] = {"lower": 1.5e-3, "upper": 2.5e-3}
    study = freeze(load_study(config))
    BestRecord("e0007", dict(ANSWER), objective=0.003).write(study.files.best)
    return study


def design(**fields) -> dict:
    """A study that takes its material from ``lab`` and frees the wall friction only."""
    config = copy.deepcopy(ANALYTIC_STUDY)
    config.update(study="chute", parameters={"sliding_friction_pw": {"lower": 0.2, "upper": 0.8}})
    del config["fixed"]
    return {**config, "material": "lab", **fields}


def test_the_calibrated_answer_and_fixed_values_become_the_material(calibrated):
    study = load_study(design())
    assert study.fixed["sliding_friction_pp"] == 0.42
    assert study.fixed["rolling_friction_pp"] == 0.11
    assert study.fixed["restitution_pp"] == 0.5  # fixed in the calibration
    assert "sliding_friction_pw" not in study.fixed  # free here
    assert study.settings["cylinder_lift"]["d50"] == 2.2e-3
    assert study.material is not None
    assert study.material["study"] == "lab" and study.material["evaluation"] == "e0007"
    assert study.material["finished"] is False and len(study.material["best_sha256"]) == 64
    assert study.warnings == []
    assert study_from_record(study_record(study)).material == study.material


@pytest.mark.parametrize("reference", ["results/lab", "results/lab/best.json"])
def test_a_folder_or_a_best_file_names_the_calibration_too(calibrated, reference):
    assert load_study(design(material=reference)).fixed["sliding_friction_pp"] == 0.42


def test_what_the_study_fixes_itself_wins_with_a_warning(calibrated):
    study = load_study(
        design(
            fixed={"sliding_friction_pp": 0.5},
            scenes={"cylinder_lift": {"settings": {"d50": 2.0e-3}}},
        )
    )
    assert study.fixed["sliding_friction_pp"] == 0.5
    assert study.settings["cylinder_lift"]["d50"] == 2.0e-3
    assert study.warnings == [
        "fixed.sliding_friction_pp = 0.5 replaces 0.42 of the calibration 'lab'",
        "scenes.cylinder_lift.settings.d50 = 0.002 replaces 0.0022 of the calibration 'lab'",
    ]


def test_a_material_from_another_engine_is_taken_with_a_warning(calibrated):
    study = load_study(design(engine={"name": "lammps"}), check_engine=False)
    assert study.fixed["sliding_friction_pp"] == 0.42
    assert study.warnings == [
        "material: the calibration 'lab' simulated with analytic, this study with lammps; "
        "their contact models differ, so its values may not carry over"
    ]


def test_a_free_setting_of_the_design_is_not_filled_in(calibrated):
    study = load_study(
        design(parameters={"d50": {"lower": 1.0e-3, "upper": 3.0e-3}}),
    )
    assert "d50" in [p.name for p in study.free]
    assert study.fixed["sliding_friction_pp"] == 0.42


@pytest.mark.parametrize(
    "reference, message",
    [
        ("nowhere", r"material: 'nowhere' names no calibration with an answer"),
        ("results/lab/other.json", r"material: 'results/lab/other.json' names no calibration"),
    ],
)
def test_a_calibration_without_an_answer_is_a_clear_error(calibrated, reference, message):
    with pytest.raises(ConfigError, match=message):
        load_study(design(material=reference))


def test_a_best_file_of_another_study_is_refused(calibrated):
    BestRecord("e0001", {"sliding_friction_pp": 0.3}, objective=0.1).write(calibrated.files.best)
    with pytest.raises(ConfigError, match=r"gives no value of d50, rolling_friction_pp"):
        load_study(design())


@pytest.mark.parametrize(
    "file, field, value",
    [
        ("best.json", "parameters.rolling_friction_pp", "0.11 (estimated)"),
        ("best.json", "parameters.d50", [2.2e-3]),
        ("best.json", "parameters.sliding_friction_pp", None),
        ("best.json", "parameters.sliding_friction_pp", True),
        ("study.json", "fixed.restitution_pp", "half"),
    ],
)
def test_a_text_where_a_number_belongs_names_the_file_and_the_field(calibrated, file, field, value):
    path = calibrated.files.dir / file
    record = json.loads(path.read_text())
    group, name = field.split(".")
    record[group][name] = value
    path.write_text(json.dumps(record))
    message = rf"material: {path.relative_to(path.parents[2])}: {field} is .*, not a number"
    with pytest.raises(ConfigError, match=message):
        load_study(design())


def test_resume_takes_a_new_provenance_but_refuses_new_values(calibrated):
    first = freeze(load_study(design()))
    (calibrated.files.finished).write_text("{}")
    assert freeze(load_study(design())).material["finished"] is True
    BestRecord("e0009", {**ANSWER, "sliding_friction_pp": 0.45}, objective=0.002).write(
        calibrated.files.best
    )
    with pytest.raises(ConfigError, match=r"fixed.sliding_friction_pp: 0.42 -> 0.45"):
        freeze(load_study(design()))
    assert first.material is not None


def write_solution_set(study, rows: list[tuple[float, float, float]]) -> None:
    """solutions.csv of ``study``: (sliding_friction_pp, rolling_friction_pp, probability)."""
    lines = ["sliding_friction_pp,rolling_friction_pp,d50,membership_probability"]
    lines += [f"{s},{r},2.2e-3,{p}" for s, r, p in rows]
    study.files.solutions.write_text("\n".join(lines) + "\n")


#: Six likely materials and two the calibration's targets rule out.
SOLUTION_SET = [(0.3 + 0.02 * i, 0.05 + 0.01 * i, 0.9) for i in range(6)] + [
    (0.8, 0.25, 0.2),
    (0.1, 0.02, 0.01),
]


def robust(**fields) -> dict:
    return design(**{"material": {"calibration": "lab", "robust": True}, "replicates": 3, **fields})


def test_a_robust_study_draws_one_likely_material_per_replicate(calibrated):
    write_solution_set(calibrated, SOLUTION_SET)
    study = load_study(robust())
    likely = {(s, r) for s, r, p in SOLUTION_SET if p >= 0.5}
    draws = study.material_draws
    assert len(draws) == 3 and len({tuple(d.items()) for d in draws}) == 3
    assert all(set(d) == {"sliding_friction_pp", "rolling_friction_pp"} for d in draws)
    assert all((d["sliding_friction_pp"], d["rolling_friction_pp"]) in likely for d in draws)
    point = {"sliding_friction_pw": 0.4}
    for replicate, draw in enumerate(draws):
        parameters = study.parameters_for(point, replicate)
        assert parameters["sliding_friction_pp"] == draw["sliding_friction_pp"]
        assert parameters["rolling_friction_pp"] == draw["rolling_friction_pp"]
        assert parameters["sliding_friction_pw"] == 0.4
        assert parameters["restitution_pp"] == 0.5
    # the objective is the loss over the draws, which the response models do not model
    assert study.objective.expected_loss and study.response_objective is None
    assert study.optimizer.strategy == "dycors"
    assert study.material is not None and len(study.material["solutions_sha256"]) == 64
    assert study_from_record(study_record(study)).material_draws == draws
    assert load_study(robust()).material_draws == draws  # the study's seed fixes the draws
    assert load_study(robust(seed=4)).material_draws != draws


def test_what_the_study_fixes_itself_is_not_drawn(calibrated):
    write_solution_set(calibrated, SOLUTION_SET)
    study = load_study(robust(fixed={"rolling_friction_pp": 0.1}))
    assert all(set(d) == {"sliding_friction_pp"} for d in study.material_draws)
    assert study.parameters_for({"sliding_friction_pw": 0.4}, 2)["rolling_friction_pp"] == 0.1


@pytest.mark.parametrize(
    "fields, rows, message",
    [
        (
            {"replicates": 1},
            SOLUTION_SET,
            r"replicates: 1; material.robust .* needs replicates >= 2",
        ),
        ({}, None, r"material.robust: no solution set of the calibration in results/lab/solutions"),
        ({"replicates": 7}, SOLUTION_SET, r"has 6 likely points, fewer than the 7 replicates"),
        (
            {"optimizer": {"strategy": "response_ei"}},
            SOLUTION_SET,
            r"optimizer.strategy: response_ei models the responses, .*material.robust",
        ),
    ],
)
def test_a_robust_study_that_cannot_draw_is_a_clear_error(calibrated, fields, rows, message):
    if rows:
        write_solution_set(calibrated, rows)
    with pytest.raises(ConfigError, match=message):
        load_study(robust(**fields))


def test_resume_refuses_other_draws(calibrated):
    write_solution_set(calibrated, SOLUTION_SET)
    freeze(load_study(robust()))
    write_solution_set(calibrated, [(s + 0.01, r, p) for s, r, p in SOLUTION_SET])
    with pytest.raises(ConfigError, match=r"drawn_materials"):
        freeze(load_study(robust()))


def test_the_expected_loss_counts_the_spread_over_materials():
    target = Target("chute", "flow_difference", 0.0, spread=2.0)
    replicates = {"chute.flow_difference": [-2.0, 2.0]}
    assert ResponseObjective((target,), "precision").of_replicates(replicates) == 0.0
    robust = ResponseObjective((target,), "precision", expected_loss=True)
    assert robust.of_replicates(replicates) == pytest.approx(1.0)  # ((-1)^2 + 1^2) / 2
    assert robust.version != ResponseObjective((target,), "precision").version
    with pytest.raises(ValueError, match="not all finite"):
        robust.of_replicates({"chute.flow_difference": [1.0, float("inf")]})
