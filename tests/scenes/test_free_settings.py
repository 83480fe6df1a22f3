"""Free scene settings (issue 21, item 3): the particle-size distribution's d50 and sigma_ln
varied beside the material parameters, as Richter & Will (2021) vary them."""

from __future__ import annotations

import copy

import pytest
from helpers import ANALYTIC_STUDY, run_calibration

from demcal.archive.store import Archive
from demcal.errors import ConfigError
from demcal.results.records import PointRecord, SimulationRecord
from demcal.study.config import load_study
from demcal.study.model import study_from_record, study_record

D50 = {"lower": 1.5e-3, "upper": 2.5e-3}


def study_config(**parameters) -> dict:
    config = copy.deepcopy(ANALYTIC_STUDY)
    config["parameters"].update(parameters)
    return config


def test_a_free_setting_is_a_dimension_that_reaches_the_scene_not_the_material():
    study = load_study(study_config(d50=D50, sigma_ln={"lower": 0.0, "upper": 0.15}))
    d50 = next(p for p in study.free if p.name == "d50")
    assert (
        d50.spec.scene_setting
        and d50.spec.unit == "m"
        and (d50.lower, d50.upper)
        == (
            1.5e-3,
            2.5e-3,
        )
    )
    point = {"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.1, "d50": 2.2e-3, "sigma_ln": 0.1}
    assert "d50" not in study.parameters_for(point)
    settings = study.settings_for("cylinder_lift", point)
    assert settings["d50"] == 2.2e-3 and settings["sigma_ln"] == 0.1
    assert settings["cylinder_diameter"] == study.settings["cylinder_lift"]["cylinder_diameter"]
    again = study_from_record(study_record(study))
    assert [p.spec for p in again.free] == [p.spec for p in study.free]


@pytest.mark.parametrize(
    "change, message",
    [
        (
            {"scenes": {"cylinder_lift": {"settings": {"d50": 2e-3}}}},
            r"scenes.cylinder_lift.settings.d50: d50 is free \(parameters.d50\)",
        ),
        ({"fixed": {"d50": 2e-3}}, r"fixed.d50: d50 is a scene setting"),
        (
            {"parameters": {"d50": {"lower": 1e-3, "upper": 0.2}}},
            r"parameters.d50.upper: 0.2 is outside the physically allowed range \[1e-05, 0.1\] m",
        ),
        (
            {"parameters": {"d50": {**D50, "unit": "mm"}}},
            r"parameters.d50.unit: 'mm' but demcal uses SI units: give d50 in m",
        ),
        (
            {"parameters": {"particle_count": {"lower": 100, "upper": 200}}},
            r"parameters.particle_count: not a parameter of the scenes cylinder_lift; "
            r"they read .*d50.*sigma_ln",
        ),
        (  # the default 25 mm cylinder holds spheres up to 25/6 mm only
            {"parameters": {"d50": {"lower": 2e-3, "upper": 5e-3}}},
            r"scenes.cylinder_lift.settings.cylinder_diameter: .* \(at d50 = 0.005, a corner "
            r"of the free bounds\)",
        ),
    ],
    ids=["also_given", "fixed", "out_of_range", "unit", "not_variable", "corner"],
)
def test_a_bad_free_setting_is_named(change, message):
    config = copy.deepcopy(ANALYTIC_STUDY)
    for key, value in change.items():
        config[key] = {**config.get(key, {}), **value}
    if "d50" not in config["parameters"] and "fixed" not in change:
        config["parameters"]["d50"] = D50
    with pytest.raises(ConfigError, match=message):
        load_study(config)


def test_a_study_with_a_free_d50_runs_it_records_it_and_a_second_study_reuses_it(
    tmp_path, monkeypatch
):
    """Every simulation runs with its point's d50; the archive keeps d50 as a free parameter,
    and a second study over the same box starts from those simulations."""
    monkeypatch.chdir(tmp_path)
    config = {
        **study_config(d50=D50),
        "study": "free-d50",
        "replicates": 1,
        "optimizer": {"max_evaluations": 6, "early_termination": {"enabled": False}},
        "calibration": {"poll_seconds": 0.001, "retries": 1},
    }
    first = run_calibration(config)
    evaluations = sorted(first.files.evals.glob("e*"))
    assert len(evaluations) >= 6
    for folder in evaluations:
        point = PointRecord.read(folder / "params.json").parameters
        simulation = SimulationRecord.read(folder / "cylinder_lift" / "rep0" / "simulation.json")
        assert simulation.settings["d50"] == point["d50"]
        assert "d50" not in simulation.parameters
    with Archive(first.study.archive) as archive:
        records = archive.records(study="free-d50")
    assert records and all("d50" in r.free and r.parameters["d50"].unit == "m" for r in records)
    assert {r.parameters["d50"].value for r in records} == {
        PointRecord.read(f / "params.json").parameters["d50"] for f in evaluations
    }
    second = run_calibration({**config, "study": "free-d50-again", "reuse": "archive"})
    assert second.optimizer.reused_points == first.optimizer.completed_evaluations()
    other_d50 = {**config, "study": "other-d50", "reuse": "archive"}
    other_d50["parameters"] = {**config["parameters"], "d50": {"lower": 3e-3, "upper": 4e-3}}
    assert run_calibration(other_d50).optimizer.reused_points == 0
