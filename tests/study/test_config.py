"""Study configuration: the shipped configs load; each kind of bad config has its own message."""

import copy
from pathlib import Path

import pytest
import yaml
from bad_inputs import BASE, ESCAPING, FIELDS, FILES, NON_FINITE
from helpers import ANALYTIC_STUDY

from demcal.errors import ConfigError
from demcal.results.records import BestRecord
from demcal.study.config import load_study, load_study_file
from demcal.study.model import freeze, load_frozen
from demcal.study.study_file import read_study_yaml

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("path", sorted((ROOT / "config").rglob("*.yaml")), ids=lambda p: p.name)
def test_shipped_configs_are_valid(path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    if "material" in read_study_yaml(path):  # a design for the default study's material
        quickstart = freeze(load_study_file(ROOT / "config" / "config.yaml"))
        answer = {"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.06}
        BestRecord("e0001", answer, objective=0.1).write(quickstart.files.best)
        rows = [f"{0.28 + 0.01 * i},{0.05 + 0.01 * i},0.9" for i in range(5)]
        quickstart.files.solutions.write_text(
            "sliding_friction_pp,rolling_friction_pp,membership_probability\n" + "\n".join(rows)
        )
    study = load_study_file(path)
    assert study.targets and study.free


def test_defaults_fill_unlisted_parameters(analytic_config):
    study = load_study(analytic_config)
    assert study.fixed["youngs_modulus"] == 5.0e6  # catalogue default
    assert study.fixed["restitution_pp"] == 0.5
    assert study.responses_needed("cylinder_lift") == ["bulk_density", "angle_of_repose"]


def test_yaml_exponent_without_sign_is_a_number_and_quoted_text_is_not(tmp_path):
    """5e6 is a number as in YAML 1.2 (PyYAML alone reads text); '5e6' in quotes stays text."""
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(BASE).replace("restitution_pp: 0.5", "youngs_modulus: 5e6"))
    assert load_study(read_study_yaml(path)).fixed["youngs_modulus"] == 5e6
    path.write_text(yaml.safe_dump(BASE).replace("restitution_pp: 0.5", "youngs_modulus: '5e6'"))
    with pytest.raises(ConfigError, match="fixed.youngs_modulus: '5e6' is text, not a number"):
        load_study_file(path)


def test_seeds_differ_per_replicate_and_repeat(analytic_config):
    study = load_study(analytic_config)
    seeds = {study.simulation_seed("e1", "cylinder_lift", r) for r in range(5)}
    assert len(seeds) == 5
    assert study.simulation_seed("e1", "cylinder_lift", 0) == study.simulation_seed(
        "e1", "cylinder_lift", 0
    )


@pytest.mark.parametrize("case", FIELDS + NON_FINITE + ESCAPING, ids=lambda c: c.name)
def test_bad_config_gets_its_own_message(case):
    """In-process, on the mapping (tests/test_bad_inputs.py gives the same cases to every route)."""
    with pytest.raises(ConfigError, match=case.message):
        load_study(case.config())


def test_bad_messages_are_distinct():
    messages = set()
    for case in FIELDS + NON_FINITE:
        with pytest.raises(ConfigError) as info:
            load_study(case.config())
        messages.add(str(info.value))
    assert len(messages) == len(FIELDS + NON_FINITE)


def test_a_target_from_the_lab_tests_repeats_takes_their_mean_and_standard_deviation(
    analytic_config,
):
    analytic_config["targets"][0] = {
        "scene": "cylinder_lift",
        "response": "angle_of_repose",
        "repeats": [24.0, 26.0, 25.5, 24.5],
    }
    target = load_study(analytic_config).targets[0]
    assert target.value == pytest.approx(25.0) and target.spread == pytest.approx(0.9128709)
    analytic_config["targets"][0]["value"] = 25.0
    with pytest.raises(ConfigError, match=r"targets\[0\].value: given together with repeats"):
        load_study(analytic_config)
    analytic_config["targets"][0] = {"scene": "cylinder_lift", "response": "angle_of_repose"}
    with pytest.raises(
        ConfigError, match=r"targets\[0\]: give the measured value .* or the lab test's repeats"
    ):
        load_study(analytic_config)


def test_the_number_of_tests_and_the_discrepancy_reach_the_target_and_its_record(
    analytic_config,
):
    """Repeats give their number as ``tests``; ``tests`` and ``discrepancy`` (converted to
    the response's unit like the value) survive the study's frozen record."""
    analytic_config["targets"][0] = {
        "scene": "cylinder_lift",
        "response": "angle_of_repose",
        "repeats": [24.0, 26.0, 25.5, 24.5],
    }
    analytic_config["targets"][1] |= {"spread": 0.01, "tests": 4, "discrepancy": 0.02}
    analytic_config["targets"][1]["unit"] = "g/cm^3"
    analytic_config["targets"][1]["value"] = 1.45
    study = load_study(analytic_config)
    repeats, density = study.targets
    assert repeats.tests == 4 and repeats.standard_error == pytest.approx(0.9128709 / 2)
    assert density.tests == 4 and density.discrepancy == pytest.approx(20.0)
    assert density.standard_error == pytest.approx(5.0)
    assert load_frozen(freeze(study).files.study).targets == study.targets


@pytest.mark.parametrize("case", FILES, ids=lambda c: c.name)
def test_a_file_that_is_not_a_readable_study_is_named(tmp_path, case):
    with pytest.raises(ConfigError, match=case.message):
        load_study_file(case.write(tmp_path))


def test_rayleigh_cost_needs_a_free_material_parameter(analytic_config):
    config = analytic_config
    config["rayleigh_cost_weight"] = 1.0
    with pytest.raises(ConfigError, match="rayleigh_cost_weight: 1 needs one of particle_density"):
        load_study(config)


def test_rayleigh_cost_enters_the_objective_of_a_stiff_point(analytic_config):
    config = analytic_config
    config["parameters"]["youngs_modulus"] = {"lower": 5.0e6, "upper": 5.0e8}
    config["rayleigh_cost_weight"] = 0.5
    study = load_study(config)
    point = {p.name: p.lower for p in study.free}
    assert study.timestep_cost(point) == pytest.approx(0.0)
    assert study.timestep_cost({**point, "youngs_modulus": 5.0e8}) == pytest.approx(0.25)


def test_centre_point_with_overrides_names_a_bad_one(analytic_config):
    study = load_study(analytic_config)
    assert study.centre_point(["rolling_friction_pp=0.05"]) == {
        "sliding_friction_pp": 0.5,
        "rolling_friction_pp": 0.05,
    }
    with pytest.raises(
        ConfigError, match="--point restitution_pp=0.3: 'restitution_pp' is not a free"
    ):
        study.centre_point(["restitution_pp=0.3"])
    with pytest.raises(ConfigError, match="--point rolling_friction_pp=x: 'x' is not a number"):
        study.centre_point(["rolling_friction_pp=x"])


def test_simulator_file_in_a_subfolder_is_fine(analytic_config):
    analytic_config["engine"] = {
        "name": "command",
        "command": "python3 sim.py",
        "responses_file": "out/responses.json",
        "partial_file": "progress.csv",
    }
    assert load_study(analytic_config, check_engine=False).engine.name == "command"


def test_early_termination_is_skipped_with_a_note_where_no_estimate_comes(analytic_config):
    """A command engine without a partial file reports no early estimate: nothing to judge,
    so replicates are not staged for it either."""
    analytic_config["engine"] = {
        "name": "command",
        "command": "python3 sim.py",
        "responses_file": "out.json",
        "partial_file": "progress.csv",
    }
    with_estimates = load_study(analytic_config, check_engine=False)
    assert with_estimates.optimizer.early_termination.enabled and with_estimates.staging == ()
    assert with_estimates.warnings == []
    del analytic_config["engine"]["partial_file"]
    study = load_study(analytic_config, check_engine=False)
    assert not study.optimizer.early_termination.enabled and study.staging is None
    assert study.warnings == [
        "optimizer.early_termination: skipped, as the command engine gives no early estimate "
        "of a response (no engine.partial_file); every simulation runs to its end"
    ]


def test_rayleigh_cost_keeps_a_strategy_that_models_it(analytic_config):
    """The response models leave the Rayleigh cost out: such studies default to dycors."""
    analytic_config["parameters"]["particle_density"] = {"lower": 2000.0, "upper": 3000.0}
    analytic_config["rayleigh_cost_weight"] = 0.5
    assert load_study(analytic_config).optimizer.strategy == "dycors"
    analytic_config["optimizer"] = {"strategy": "response_ei"}
    with pytest.raises(
        ConfigError,
        match="optimizer.strategy: response_ei models the responses, which does not capture "
        "rayleigh_cost_weight 0.5",
    ):
        load_study(analytic_config)
    del analytic_config["rayleigh_cost_weight"]
    assert load_study(analytic_config).optimizer.strategy == "response_ei"


@pytest.mark.parametrize("where", ["fixed", "parameters"])
def test_the_one_restitution_of_earlier_versions_names_its_two_successors(analytic_config, where):
    config = {**analytic_config, "fixed": {}, "parameters": dict(analytic_config["parameters"])}
    config[where]["restitution"] = 0.5 if where == "fixed" else {"lower": 0.2, "upper": 0.8}
    with pytest.raises(
        ConfigError, match=rf"{where}.restitution: demcal now has restitution_pp and restitution_pw"
    ):
        load_study(config)


def test_restitution_and_rolling_damping_reach_each_contact(analytic_config):
    """Rackl & Hanley (2017), Table 1: e_pp 0.89, e_pw 0.60, rolling damping 0.25."""
    table_1 = {"restitution_pp": 0.89, "restitution_pw": 0.6, "rolling_damping_ratio": 0.25}
    study = load_study({**analytic_config, "fixed": table_1})
    assert {name: study.fixed[name] for name in table_1} == table_1


@pytest.mark.parametrize(
    ("target", "expected"),
    [
        ({"response": "angle_of_repose", "value": 0.5, "unit": "rad", "spread": 0.02}, 28.65),
        ({"response": "bulk_density", "value": 1.45, "unit": "g/cm^3", "spread": 0.01}, 1450.0),
        ({"response": "bulk_density", "repeats": [1.44, 1.46], "unit": "t/m3"}, 1450.0),
    ],
)
def test_a_target_in_a_convertible_unit_is_converted_and_said(target, expected):
    """A lab sheet's units (issue 36, item 8): converted once, with a note naming both."""
    config = copy.deepcopy(ANALYTIC_STUDY)
    config["targets"] = [{"scene": "cylinder_lift", **target}]
    study = load_study(config)
    assert study.targets[0].value == pytest.approx(expected, rel=1e-3)
    note = next(w for w in study.warnings if w.startswith("targets[0]: converted"))
    assert (
        target["unit"] in note
        and study.scenes["cylinder_lift"].responses[target["response"]].unit in note
    )
    if "spread" in target:
        factor = study.targets[0].value / target["value"]
        assert study.targets[0].spread == pytest.approx(target["spread"] * factor)


def test_an_engine_that_does_not_model_adhesion_refuses_a_surface_energy(analytic_config):
    analytic_config["engine"] = {"name": "liggghts"}
    analytic_config["parameters"]["surface_energy_pp"] = {"lower": 0.0, "upper": 0.5}
    with pytest.raises(ConfigError) as error:
        load_study(analytic_config, check_engine=False)
    assert str(error.value) == (
        "parameters.surface_energy_pp: engine liggghts does not model it; fix it at 0 or use "
        "engine lammps"
    )
    del analytic_config["parameters"]["surface_energy_pp"]
    analytic_config["fixed"]["surface_energy_pw"] = 0.1
    with pytest.raises(ConfigError, match="^fixed.surface_energy_pw: engine liggghts"):
        load_study(analytic_config, check_engine=False)
    analytic_config["fixed"]["surface_energy_pw"] = 0.0
    assert load_study(analytic_config, check_engine=False).fixed["surface_energy_pw"] == 0.0


def test_a_free_surface_energy_notes_that_the_time_step_may_follow_it(analytic_config):
    analytic_config["engine"] = {"name": "lammps"}
    analytic_config["parameters"]["surface_energy_pp"] = {"lower": 0.0, "upper": 0.5}
    study = load_study(analytic_config, check_engine=False)
    assert any(
        w.startswith("parameters.surface_energy_pp: adhesion can shorten the time step")
        for w in study.warnings
    )
