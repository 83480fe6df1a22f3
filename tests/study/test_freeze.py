"""The frozen study (results/<study>/study.json) and what may change when a calibration resumes."""

from __future__ import annotations

import json
from statistics import fmean

import pytest
from helpers import analytic_example, read_objective, run_in_process

from demcal.daemon.loop import Calibration
from demcal.errors import ConfigError
from demcal.study.config import load_study
from demcal.study.model import freeze, incompatible_changes, load_frozen, study_record

FAST = {"response_model": "cubic_rbf"}


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """An empty working directory: results/ is relative to it."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def frozen_record(study) -> dict:
    return json.loads(study.files.study.read_text())


def test_freeze_writes_the_resolved_study_and_returns_what_jobs_read(workdir):
    study = load_study(analytic_example())
    frozen = freeze(study)
    record = frozen_record(study)
    assert record["study"] == "analytic-demo"
    assert [(p["name"], p["lower"], p["upper"]) for p in record["parameters"]] == [
        ("sliding_friction_pp", 0.1, 0.9),
        ("rolling_friction_pp", 0.02, 0.3),
    ]
    # defaults are resolved in the frozen copy, units come from the scene
    assert record["objective"] == "relative"
    assert record["optimizer"]["strategy"] == "response_ei"
    assert record["optimizer"]["max_evaluations"] == 30
    assert [(t["response"], t["value"], t["unit"]) for t in record["targets"]] == [
        ("angle_of_repose", 25.0, "deg"),
        ("bulk_density", 1450.0, "kg/m^3"),
    ]
    assert record["engine"] == {"name": "analytic", "noise": 0.01, "duration": 0.0}
    # the returned study is the one read back from the file, the same as the original
    assert (
        study_record(frozen) == study_record(study) == study_record(load_frozen(study.files.study))
    )


def test_freezing_the_same_study_again_keeps_the_file(workdir):
    freeze(load_study(analytic_example()))
    first = load_study(analytic_example()).files.study.read_text()
    freeze(load_study(analytic_example()))
    assert load_study(analytic_example()).files.study.read_text() == first


def test_a_resumable_change_is_accepted_and_frozen(workdir):
    freeze(load_study(analytic_example()))
    changed = analytic_example(
        optimizer={"max_evaluations": 60, "no_improvement_evaluations": 12},
        calibration={"poll_seconds": 7.5, "retries": 4},
    )
    old = frozen_record(load_study(changed))
    assert incompatible_changes(old, study_record(load_study(changed))) == []
    frozen = freeze(load_study(changed))
    assert frozen.optimizer.max_evaluations == 60
    assert frozen.optimizer.no_improvement_evaluations == 12
    assert frozen.calibration["poll_seconds"] == 7.5
    record = frozen_record(frozen)
    assert record["optimizer"]["max_evaluations"] == 60
    assert record["calibration"]["retries"] == 4


def test_a_study_begun_before_adhesion_resumes(workdir):
    """A study frozen by a demcal whose materials had no surface energy resumes unchanged:
    its cohesionless material is today's with both surface energies 0."""
    study = load_study(analytic_example())
    freeze(study)
    record = frozen_record(study)
    for name in ("surface_energy_pp", "surface_energy_pw"):
        del record["fixed"][name]
    study.files.study.write_text(json.dumps(record))
    assert freeze(load_study(analytic_example())).fixed["surface_energy_pp"] == 0.0


@pytest.mark.parametrize(
    "overrides, field, shown",
    [
        (
            {"parameters": {"sliding_friction_pp": {"lower": 0.1, "upper": 0.8}}},
            "parameters[0].upper",
            "0.9 -> 0.8",
        ),
        ({"seed": 8}, "seed", "7 -> 8"),
        ({"replicates": 3}, "replicates", "2 -> 3"),
        ({"fixed": {"restitution_pp": 0.6}}, "fixed.restitution_pp", "0.5 -> 0.6"),
        ({"engine": {"noise": 0.02}}, "engine.noise", "0.01 -> 0.02"),
        ({"optimizer": {"strategy": "dycors"}}, "optimizer.strategy", "'response_ei' -> 'dycors'"),
        ({"staging": "parallel"}, "staging", "[] -> None"),
    ],
)
def test_an_incompatible_change_is_refused_naming_the_field(workdir, overrides, field, shown):
    study = freeze(load_study(analytic_example()))
    before = study.files.study.read_text()
    with pytest.raises(ConfigError) as refused:
        freeze(load_study(analytic_example(**overrides)))
    message = str(refused.value)
    assert f"{field}: {shown}" in message
    assert "give the study a new name" in message
    assert study.files.study.read_text() == before  # the frozen copy is left as it was


def test_a_study_begun_before_staging_keeps_its_evaluations_running_at_once(workdir):
    study = freeze(load_study(analytic_example()))
    assert study.staging == ()
    record = frozen_record(study)
    del record["staging"]
    study.files.study.write_text(json.dumps(record))
    assert freeze(load_study(analytic_example())).staging is None
    assert load_frozen(study.files.study).staging is None


def test_a_different_targeted_response_is_refused(workdir):
    freeze(load_study(analytic_example()))
    config = analytic_example()
    config["targets"][1] = {"scene": "cylinder_lift", "response": "angle_of_repose", "value": 26.0}
    config["targets"][0] = {"scene": "cylinder_lift", "response": "bulk_density", "value": 1450.0}
    with pytest.raises(ConfigError, match=r"targets\[0\]\.response: 'angle_of_repose' -> "):
        freeze(load_study(config))


def test_target_values_may_change_only_while_the_same_responses_are_targeted():
    old = {"targets": [{"scene": "s", "response": "a", "value": 1.0, "weight": 1.0}]}
    corrected = {"targets": [{"scene": "s", "response": "a", "value": 2.0, "weight": 3.0}]}
    assert incompatible_changes(old, corrected) == []
    added = {"targets": [*corrected["targets"], {"scene": "s", "response": "b", "value": 5.0}]}
    assert incompatible_changes(old, added) == ["targets"]
    renamed = {"targets": [{"scene": "s", "response": "b", "value": 2.0, "weight": 3.0}]}
    assert incompatible_changes(old, renamed) == [
        "targets[0].response",
        "targets[0].value",
        "targets[0].weight",
    ]


def test_a_damaged_frozen_study_is_refused_with_the_way_out(workdir):
    study = load_study(analytic_example())
    study.files.dir.mkdir(parents=True)
    study.files.study.write_text('{"study": "analytic-demo", ')
    with pytest.raises(ConfigError, match="unreadable.*move it away to start the study afresh"):
        freeze(study)


def test_a_target_correction_is_accepted_and_rescores_the_stored_evaluations(workdir):
    study = freeze(load_study(analytic_example(optimizer=FAST)))
    run_in_process(study, 3)
    before = [read_objective(files) for files in study.files.evaluations()]
    assert {record["scored_with"] for record in before} == {study.objective.version}

    corrected = analytic_example(optimizer=FAST)
    corrected["targets"][0].update(value=30.0, weight=2.0)
    calibration = Calibration(freeze(load_study(corrected)), None, 1)

    for old, files, told in zip(before, study.files.evaluations(), calibration.optimizer.records):
        new = read_objective(files)
        assert files.rescored.exists()  # the job's objective.json stays as it wrote it
        assert json.loads(files.objective.read_text()) == old
        assert new["scored_with"] == calibration.study.objective.version != old["scored_with"]
        assert new["replicates"] == old["replicates"]  # re-scored, not simulated again
        angle = fmean(new["replicates"]["cylinder_lift.angle_of_repose"])
        density = fmean(new["replicates"]["cylinder_lift.bulk_density"])
        expected = 2.0 * ((angle - 30.0) / 30.0) ** 2 + ((density - 1450.0) / 1450.0) ** 2
        assert new["objective"] == pytest.approx(expected, rel=1e-12)
        assert new["objective"] != pytest.approx(old["objective"], rel=1e-3)
        assert told.value == pytest.approx(expected, rel=1e-12)


def test_a_study_frozen_with_one_restitution_is_read_with_both(tmp_path, monkeypatch):
    """study.json of an earlier demcal: restitution free and fixed become the two of today."""
    import copy

    from helpers import ANALYTIC_STUDY

    from demcal.study.config import load_study
    from demcal.study.model import study_from_record, study_record

    monkeypatch.chdir(tmp_path)
    record = study_record(load_study(copy.deepcopy(ANALYTIC_STUDY)))
    record["parameters"].append({"name": "restitution", "lower": 0.2, "upper": 0.8, "unit": "-"})
    record["fixed"] = {n: v for n, v in record["fixed"].items() if not n.startswith("restitution")}
    study = study_from_record(record)
    assert [p.name for p in study.free][-2:] == ["restitution_pp", "restitution_pw"]
    assert (study.free[-1].lower, study.free[-1].upper) == (0.2, 0.8)


@pytest.mark.parametrize("name", ["surface_energy_pp", "rolling_damping_ratio"])
def test_a_study_that_frees_an_earlier_constant_resumes(workdir, name):
    """A parameter earlier demcals held constant (surface energy, the rolling damping ratio)
    is free: the study's fixed values leave it out, so resuming compares equal (it was
    refused as 'fixed.<name>: 0.0 -> None', and jobs read it as both free and fixed)."""
    bounds = {"surface_energy_pp": (0.0, 0.1), "rolling_damping_ratio": (0.1, 0.9)}[name]
    config = analytic_example(parameters={name: {"lower": bounds[0], "upper": bounds[1]}})
    frozen = freeze(load_study(config))
    assert name in [p.name for p in frozen.free] and name not in frozen.fixed
    again = freeze(load_study(config))  # the calibration resumes
    assert again.fixed == frozen.fixed
