"""Study configuration: the shipped configs load; each kind of bad config has its own message."""

import re
from pathlib import Path

import pytest
import yaml

from demcal.config import load_study, load_study_file
from demcal.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("path", sorted((ROOT / "config").rglob("*.yaml")), ids=lambda p: p.name)
def test_shipped_configs_are_valid(path):
    study = load_study_file(path)
    assert study.targets and study.free


def test_defaults_fill_unlisted_parameters(analytic_config):
    study = load_study(analytic_config)
    assert study.fixed["youngs_modulus"] == 5.0e6  # catalogue default
    assert study.fixed["restitution"] == 0.5
    assert study.responses_needed("cylinder_lift") == ["bulk_density", "angle_of_repose"]


def test_yaml_exponent_without_sign_is_a_number(analytic_config):
    analytic_config["fixed"]["youngs_modulus"] = yaml.safe_load("5e6")  # PyYAML: the string '5e6'
    assert load_study(analytic_config).fixed["youngs_modulus"] == 5e6


def test_seeds_differ_per_replicate_and_repeat(analytic_config):
    study = load_study(analytic_config)
    seeds = {study.simulation_seed("e1", "cylinder_lift", r) for r in range(5)}
    assert len(seeds) == 5
    assert study.simulation_seed("e1", "cylinder_lift", 0) == study.simulation_seed(
        "e1", "cylinder_lift", 0)


def _set(config, path, value):
    *head, last = path
    node = config
    for key in head:
        node = node[key]
    if value is KeyError:
        del node[last]
    else:
        node[last] = value


BAD = [
    # (where, value, expected message fragment)
    (["colour"], "red", r"colour: unknown field; allowed here: .*engine"),
    (["targets"], KeyError, r"missing required field 'targets'"),
    (["study"], "../escape", r"study: '../escape' is not a valid name"),
    (["engine", "name"], "dem2000", r"engine.name: 'dem2000' is not one of lammps, analytic, command"),
    (["parameters", "stiffness"], {"lower": 1, "upper": 2},
     r"parameters.stiffness: not a parameter of the scenes cylinder_lift; they read"),
    (["parameters", "sliding_friction_pp"], {"lower": 0.9, "upper": 0.1},
     r"parameters.sliding_friction_pp: lower bound 0.9 must be less than upper bound 0.1"),
    (["parameters", "rolling_friction_pp"], {"lower": 0.1, "upper": 3.0},
     r"parameters.rolling_friction_pp.upper: 3 is outside the physically allowed range \[0, 1\]"),
    (["parameters", "sliding_friction_pp", "unit"], "deg",
     r"parameters.sliding_friction_pp.unit: 'deg' but demcal uses SI units"),
    (["fixed", "sliding_friction_pp"], 0.5,
     r"fixed.sliding_friction_pp: sliding_friction_pp is also a free parameter"),
    (["fixed", "youngs_modulus"], -1.0,
     r"fixed.youngs_modulus: -1 is outside the physically allowed range \[100000, 1e\+12\] Pa"),
    (["targets", 0, "response"], "shear_angle",
     r"targets\[0\].response: scene 'cylinder_lift' cannot produce 'shear_angle'"),
    (["targets", 0, "scene"], "drop_test", r"targets\[0\].scene: 'drop_test' is not a known scene"),
    (["targets", 1, "weight"], -1.0, r"targets\[1\].weight: -1.0 must be > 0"),
    (["targets", 0, "unit"], "rad", r"targets\[0\].unit: 'rad' but angle_of_repose is measured in deg"),
    (["timestep_fraction"], 0.75, r"timestep_fraction: 0.75 is above 0.5 of the Rayleigh time"),
    (["replicates"], 0, r"replicates: 0 must be >= 1"),
    (["scenes"], {"cylinder_lift": {"settings": {"lift_sped": 0.01}}},
     r"scenes.cylinder_lift.settings.lift_sped: unknown setting for scene 'cylinder_lift'"),
    (["scenes"], {"cylinder_lift": {"settings": {"lift_speed": -0.01}}},
     r"scenes.cylinder_lift.settings.lift_speed: -0.01 is outside the allowed range"),
    (["scenes"], {"cylinder_lift": {"settings": {"cylinder_diameter": 0.005}}},
     r"scenes.cylinder_lift.settings.cylinder_diameter: 0.005 m is less than 6 of the largest"),
    (["scenes"], {"cylinder_lift": {"settings": {"aor_method": "eyeball"}}},
     r"scenes.cylinder_lift.settings.aor_method: 'eyeball' is not allowed; use one of flank_fit"),
    (["engine"], {"name": "command", "command": "no-such-simulator -in {input}",
                  "responses_file": "r.json"},
     r"engine.command: executable 'no-such-simulator' not found on PATH"),
    (["engine"], {"name": "command", "command": "python3 sim.py {friction}",
                  "responses_file": "r.json"},
     r"engine.command: unknown placeholder \{friction\}"),
    *[(["engine"], {"name": "command", "command": f"python3 sim.py {word}", "responses_file": "r.json"},
       r"engine.command: .*placeholders are plain names") for word in ("{}", "{seed:d}", "{seed:>300000}",
                                                                       "{seed!r}", "{seed[0]}", "{seed.real}")],
    (["engine"], {"name": "command", "command": "python3 sim.py {seed", "responses_file": "r.json"},
     r"engine.command: '\{seed': .*write a literal brace as \{\{"),
    (["engine", "duration"], -2, r"engine.duration: -2 must be >= 0"),
    (["engine", "failures"], [{"when": {"density": [0, 1]}}],
     r"engine.failures\[0\].when.density: not a parameter of the study's scenes"),
]


@pytest.mark.parametrize("where,value,message", BAD, ids=[".".join(map(str, b[0])) for b in BAD])
def test_bad_config_gets_its_own_message(analytic_config, where, value, message):
    _set(analytic_config, where, value)
    with pytest.raises(ConfigError, match=message):
        load_study(analytic_config)


def test_bad_messages_are_distinct(analytic_config):
    import copy
    messages = set()
    for where, value, _ in BAD:
        config = copy.deepcopy(analytic_config)
        _set(config, where, value)
        with pytest.raises(ConfigError) as info:
            load_study(config)
        messages.add(str(info.value))
    assert len(messages) == len(BAD)


def test_missing_file_and_bad_yaml(tmp_path):
    with pytest.raises(ConfigError, match="configuration file not found"):
        load_study_file(tmp_path / "none.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("study: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_study_file(bad)


def test_a_target_from_the_lab_tests_repeats_takes_their_mean_and_standard_deviation(analytic_config):
    analytic_config["targets"][0] = {"scene": "cylinder_lift", "response": "angle_of_repose",
                                     "repeats": [24.0, 26.0, 25.5, 24.5]}
    target = load_study(analytic_config).targets[0]
    assert target.value == pytest.approx(25.0) and target.spread == pytest.approx(0.9128709)
    analytic_config["targets"][0]["value"] = 25.0
    with pytest.raises(ConfigError, match=r"targets\[0\].value: given together with repeats"):
        load_study(analytic_config)
    analytic_config["targets"][0] = {"scene": "cylinder_lift", "response": "angle_of_repose"}
    with pytest.raises(ConfigError, match=r"targets\[0\]: give the measured value .* or the lab test's repeats"):
        load_study(analytic_config)


def test_duplicate_keys_non_utf8_and_directories_are_one_clear_message(tmp_path):
    twice = tmp_path / "twice.yaml"
    twice.write_text("study: a\nseed: 1\nreplicates: 2\nseed: 3\n")
    with pytest.raises(ConfigError, match=r"twice.yaml: duplicate key 'seed' \(line 4\): YAML would silently"):
        load_study_file(twice)
    latin = tmp_path / "latin.yaml"
    latin.write_bytes("study: m\u00fcller\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"latin.yaml: not UTF-8 text"):
        load_study_file(latin)
    with pytest.raises(ConfigError, match=r"is a directory; give the study's YAML file"):
        load_study_file(tmp_path)
    listing = tmp_path / "list.yaml"
    listing.write_text("- study: a\n")
    with pytest.raises(ConfigError, match=r"list.yaml: a study file is a YAML mapping"):
        load_study_file(listing)


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
        "sliding_friction_pp": 0.5, "rolling_friction_pp": 0.05}
    with pytest.raises(ConfigError, match="--point restitution=0.3: 'restitution' is not a free"):
        study.centre_point(["restitution=0.3"])
    with pytest.raises(ConfigError, match="--point rolling_friction_pp=x: 'x' is not a number"):
        study.centre_point(["rolling_friction_pp=x"])


NON_FINITE = [
    (["targets", 0, "value"], ".nan", r"targets\[0\].value: nan is not a finite number"),
    (["targets", 1, "weight"], ".inf", r"targets\[1\].weight: inf is not a finite number"),
    (["targets", 1, "spread"], ".nan", r"targets\[1\].spread: nan is not a finite number"),
    (["parameters", "sliding_friction_pp", "upper"], ".inf",
     r"parameters.sliding_friction_pp.upper: inf is not a finite number"),
    (["fixed", "restitution"], "-.inf", r"fixed.restitution: -inf is not a finite number"),
    (["timestep_fraction"], ".nan", r"timestep_fraction: nan is not a finite number"),
    (["calibration"], "{poll_seconds: .nan}", r"calibration.poll_seconds: nan is not a finite"),
    (["optimizer"], "{max_seconds: .inf}", r"optimizer.max_seconds: inf is not a finite"),
    (["scenes"], "{cylinder_lift: {settings: {lift_speed: .nan}}}",
     r"scenes.cylinder_lift.settings.lift_speed: nan is not a finite"),
    (["engine"], "{name: command, command: 'python3 s.py', responses_file: r.json, "
                 "timeout: .nan}", r"engine.timeout: nan is not a finite number"),
    (["engine"], "{name: analytic, noise: 1e999}", r"engine.noise: inf is not a finite number"),
]


@pytest.mark.parametrize("where,text,message", NON_FINITE,
                         ids=[".".join(map(str, b[0])) for b in NON_FINITE])
def test_non_finite_numbers_are_refused_by_field(analytic_config, where, text, message):
    """YAML's .nan/.inf pass JSON Schema's range checks; every field refuses them by name."""
    _set(analytic_config, where, yaml.safe_load(text))
    with pytest.raises(ConfigError, match=message):
        load_study(analytic_config)


ESCAPING_PATHS = ["/tmp/demcal-victim.json", "../../params.json", "../../../../tmp/x",
                  "out/../../x.json", "simulation.json", "partial.csv", "", "out/"]


@pytest.mark.parametrize("key", ["responses_file", "partial_file"])
@pytest.mark.parametrize("path", ESCAPING_PATHS)
def test_simulator_files_must_stay_in_the_run_directory(analytic_config, key, path):
    """The command engine deletes responses_file before each run: no path may leave the run dir."""
    analytic_config["engine"] = {"name": "command", "command": "python3 sim.py",
                                 "responses_file": "out.json", key: path}
    with pytest.raises(ConfigError, match=rf"engine.{key}: '{re.escape(path)}' "):
        load_study(analytic_config, check_engine=False)


def test_simulator_file_in_a_subfolder_is_fine(analytic_config):
    analytic_config["engine"] = {"name": "command", "command": "python3 sim.py",
                                 "responses_file": "out/responses.json",
                                 "partial_file": "progress.csv"}
    assert load_study(analytic_config, check_engine=False).engine.name == "command"


def test_rayleigh_cost_keeps_a_strategy_that_models_it(analytic_config):
    """The response models leave the Rayleigh cost out: such studies default to dycors."""
    analytic_config["parameters"]["particle_density"] = {"lower": 2000.0, "upper": 3000.0}
    analytic_config["rayleigh_cost_weight"] = 0.5
    assert load_study(analytic_config).optimizer.strategy == "dycors"
    analytic_config["optimizer"] = {"strategy": "response_ei"}
    with pytest.raises(ConfigError, match="optimizer.strategy: response_ei does not model the Rayleigh"):
        load_study(analytic_config)
    del analytic_config["rayleigh_cost_weight"]
    assert load_study(analytic_config).optimizer.strategy == "response_ei"
