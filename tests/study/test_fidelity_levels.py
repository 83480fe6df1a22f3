"""Fidelity levels in a study (issue 38, item 1): the default coarse level of each scene,
given overrides, the checks that refuse a level, and the level in study.json."""

from __future__ import annotations

import copy

import pytest
from helpers import ANALYTIC_STUDY

from demcal.errors import ConfigError
from demcal.results.records import FINE
from demcal.scenes import SCENES
from demcal.scenes.base import COARSE_PARTICLE_FACTOR
from demcal.study.config import load_study
from demcal.study.model import freeze, study_from_record, study_record


def with_levels(levels: dict, **changes) -> dict:
    return {**copy.deepcopy(ANALYTIC_STUDY), "fidelities": levels, **changes}


def test_the_default_coarse_level_keeps_the_fill_with_a_quarter_of_the_particles():
    study = load_study(with_levels({"coarse": "default"}))
    fine, coarse = study.level(FINE), study.level("coarse")
    assert study.levels == [FINE, "coarse"]
    lift_fine, lift_coarse = fine.settings["cylinder_lift"], coarse.settings["cylinder_lift"]
    assert lift_coarse["particle_count"] == lift_fine["particle_count"] / COARSE_PARTICLE_FACTOR
    volume = lambda s: s["particle_count"] * s["d50"] ** 3  # noqa: E731
    assert volume(lift_coarse) == pytest.approx(volume(lift_fine))
    assert coarse.timestep_fraction == fine.timestep_fraction
    # every other setting is the fine level's
    changed = {k for k in lift_fine if lift_fine[k] != lift_coarse[k]}
    assert changed == {"particle_count", "d50"}


@pytest.mark.parametrize("scene", list(SCENES))
def test_every_scene_has_a_default_coarse_level_that_its_checks_accept(scene):
    spec = SCENES.load(scene)
    fine = spec.resolve_settings({}, "settings")
    changed = spec.coarse(fine)
    assert changed and all(fine[name] != value for name, value in changed.items())
    spec.resolve_settings({**fine, **changed}, "settings")


def test_a_level_overrides_settings_time_step_and_engine_settings():
    study = load_study(
        with_levels(
            {
                "cheap": {
                    "scenes": {"cylinder_lift": {"settings": {"particle_count": 300}}},
                    "timestep_fraction": 0.35,
                    "engine": {"noise": 0.05, "scale": 0.9},
                }
            }
        )
    )
    cheap = study.level("cheap")
    assert cheap.settings["cylinder_lift"]["particle_count"] == 300
    assert cheap.timestep_fraction == 0.35
    assert cheap.engine.settings == {"noise": 0.05, "scale": 0.9}
    assert study.engine.settings == {"noise": 0.0}
    assert any(w.startswith("fidelities.cheap.timestep_fraction: 0.35") for w in study.warnings)
    assert study.simulator("cylinder_lift", "cheap") != study.simulator("cylinder_lift")


@pytest.mark.parametrize(
    ("levels", "message"),
    [
        ({"fine": "default"}, "fidelities.fine: 'fine' names the study's own settings"),
        ({"same": {"timestep_fraction": 0.25}}, "fidelities.same: simulates exactly what"),
        (
            {"c": {"scenes": {"cylinder_lift": {"settings": {"particle_count": 5}}}}},
            r"fidelities.c.scenes.cylinder_lift.settings.particle_count: 5 is outside",
        ),
        (
            {"c": {"scenes": {"cylinder_lift": {"settings": {"d50": 5.0e-3}}}}},
            r"fidelities.c.scenes.cylinder_lift.settings.cylinder_diameter: .* less than 6",
        ),
        (
            {"c": {"scenes": {"shear_box": {"settings": {"box_size_dmax": 6}}}}},
            "fidelities.c.scenes.shear_box: not a scene of the study",
        ),
        ({"c": {"engine": {"name": "lammps"}}}, "fidelities.c.engine.name: a level runs on"),
        ({"c": {"engine": {"noise": 2}}}, r"fidelities.c.engine.noise: .*"),
        ({"c": {"timestep_fraction": 0.8}}, "fidelities.c.timestep_fraction: 0.8 is above"),
        ({"c": "coarse"}, r"fidelities.c: 'coarse' is not allowed"),
        ({"c": {}}, "fidelities.c: none given; give at least 1"),
    ],
)
def test_a_bad_level_is_refused_naming_its_field(levels, message):
    with pytest.raises(ConfigError, match=message):
        load_study(with_levels(levels))


def test_the_default_level_does_not_change_a_free_setting():
    free_d50 = copy.deepcopy(ANALYTIC_STUDY["parameters"]) | {
        "d50": {"lower": 1.5e-3, "upper": 2.5e-3}
    }
    with pytest.raises(ConfigError, match="default coarse level of cylinder_lift changes d50"):
        load_study(with_levels({"coarse": "default"}, parameters=free_d50))
    # given settings that leave d50 alone are checked at the corners of its bounds
    study = load_study(
        with_levels(
            {"c": {"scenes": {"cylinder_lift": {"settings": {"particle_count": 600}}}}},
            parameters=free_d50,
        )
    )
    assert study.settings_for("cylinder_lift", {"d50": 2.2e-3}, "c")["d50"] == 2.2e-3


def test_levels_survive_study_json_and_a_level_may_be_added_on_resume(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(with_levels({"coarse": "default"})))
    again, level = study_from_record(study_record(study)).level("coarse"), study.level("coarse")
    assert again.settings == level.settings and again.timestep_fraction == level.timestep_fraction
    assert again.engine.outcome() == level.engine.outcome()
    freeze(load_study(with_levels({"coarse": "default", "fast": {"timestep_fraction": 0.3}})))
    changed = {"particle_count": 100}
    with pytest.raises(ConfigError, match="fidelities.coarse.scenes.cylinder_lift.particle_count"):
        freeze(
            load_study(
                with_levels({"coarse": {"scenes": {"cylinder_lift": {"settings": changed}}}})
            )
        )
    with pytest.raises(ConfigError, match="fidelity 'nope': the study has no such level"):
        study.level("nope")
