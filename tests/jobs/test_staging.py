"""Staged evaluations: which simulation waits for which, which never starts, and what a
study's ``staging`` resolves to (in-process; tests/workflow/test_workflow.py runs them
through Snakemake)."""

from __future__ import annotations

import pytest
from helpers import ANALYTIC_STUDY, analytic_example

from demcal.jobs.steps import not_started, staged_inputs
from demcal.results.records import PointRecord, ResponsesRecord, Status
from demcal.study.config import load_study

JOINT = {
    **ANALYTIC_STUDY,
    "parameters": {
        **ANALYTIC_STUDY["parameters"],
        "sliding_friction_pw": {"lower": 0.2, "upper": 0.9},
    },
    "targets": [
        *ANALYTIC_STUDY["targets"],
        {"scene": "calibration_device", "response": "mass_flow", "value": 0.02},
    ],
    "replicates": 3,
}


@pytest.fixture
def joint(tmp_path, monkeypatch):
    """A staged study of two scenes x 3 replicates, device first, and one evaluation e1."""
    monkeypatch.chdir(tmp_path)
    study = load_study({**JOINT, "staging": ["calibration_device", "cylinder_lift"]})
    study.files.evaluation("e1").dir.mkdir(parents=True)
    return study


def point(study, staged: bool) -> None:
    PointRecord({"sliding_friction_pp": 0.4}, staged=staged).write(
        study.files.evaluation("e1").params
    )


def names(paths) -> list[str]:
    return [f"{p.parent.parent.name}/{p.parent.name}" for p in paths]


def test_first_replicates_in_the_scene_order_then_the_rest(joint):
    point(joint, staged=True)
    assert staged_inputs(joint, "e1", "calibration_device", 0) == []
    assert names(staged_inputs(joint, "e1", "cylinder_lift", 0)) == ["calibration_device/rep0"]
    for scene in ("cylinder_lift", "calibration_device"):
        assert sorted(names(staged_inputs(joint, "e1", scene, 2))) == [
            "calibration_device/rep0",
            "cylinder_lift/rep0",
        ]


def test_an_evaluation_that_cannot_be_stopped_runs_all_at_once(joint):
    point(joint, staged=False)  # the initial design, a confirmation, a campaign's point
    assert staged_inputs(joint, "e1", "cylinder_lift", 2) == []
    (joint.files.evaluation("e1").params).write_text("not json")
    assert staged_inputs(joint, "e1", "cylinder_lift", 2) == []


def test_what_is_not_started_and_why(joint):
    point(joint, staged=True)
    files = joint.files.evaluation("e1")
    assert not_started(joint, "e1", "cylinder_lift", 1) is None  # inputs not there: run
    first = files.replicate("calibration_device", 0).responses
    first.parent.mkdir(parents=True)
    ResponsesRecord(Status.FAILED, "particles escaped").write(first)
    result = not_started(joint, "e1", "cylinder_lift", 0)
    assert result is not None and result.status == Status.TERMINATED
    assert result.reason == "not started: calibration_device rep0 failed"
    ResponsesRecord(Status.OK, responses={"mass_flow": 0.02}).write(first)
    assert not_started(joint, "e1", "cylinder_lift", 0) is None
    files.stop.touch()
    result = not_started(joint, "e1", "calibration_device", 0)
    assert result is not None
    assert result.reason == "not started: the evaluation was stopped early"


@pytest.mark.parametrize(
    "overrides, staging",
    [
        ({}, ()),  # early termination on by default: staged
        ({"optimizer": {"early_termination": {"enabled": False}}}, None),
        ({"optimizer": {"strategy": "rackl_hanley"}}, None),  # it never stops a run
        ({"staging": "parallel"}, None),
        ({"staging": "staged", "optimizer": {"early_termination": {"enabled": False}}}, ()),
    ],
)
def test_auto_stages_where_early_termination_can_stop_runs(overrides, staging):
    assert load_study(analytic_example(**overrides), check_engine=False).staging == staging
