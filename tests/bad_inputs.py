"""The bad-input corpus: study files and hand-written points that demcal must refuse by name.

Every case goes through both routes a user has, ``demcal run FILE`` and the
README's ``snakemake --profile profiles/<local|slurm> --configfile=FILE``
(tests/test_bad_inputs.py), and must end in one line naming the field or
file, with no traceback, no simulation started and nothing written outside
``results/``. ``benchmarks/bad_inputs.py`` counts how each route handles the
corpus (clean, traceback, silent, wrongly accepted). tests/study/test_config.py
checks the config cases in-process against ``load_study`` as well.

A case is a mutation of ``BASE`` (``where`` a path of keys, ``value`` the
new value or ``KeyError`` to delete), or a file's raw bytes, or a path that
is not a readable file; ``message`` is a regular expression the line must
match.
"""

from __future__ import annotations

import copy
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from helpers import ANALYTIC_STUDY

ROOT = Path(__file__).resolve().parents[1]

#: A valid study: two evaluations on the analytic engine if a bad case were accepted.
BASE = {**copy.deepcopy(ANALYTIC_STUDY), "study": "corpus", "optimizer": {"max_evaluations": 2}}


def changed(config: dict, where: list, value) -> dict:
    """``config`` with the field at ``where`` set to ``value`` (deleted for ``KeyError``)."""
    config = copy.deepcopy(config)
    *head, last = where
    node = config
    for key in head:
        node = node[key]
    if value is KeyError:
        del node[last]
    else:
        node[last] = value
    return config


@dataclass(frozen=True)
class BadInput:
    """One bad input and the message its refusal must carry."""

    name: str
    message: str
    where: list = field(default_factory=list)
    value: object = None
    raw: bytes | None = None  # the file's bytes instead of a changed BASE
    path_kind: str = "file"  # file | directory | missing
    engine_input: bool = False  # the command engine's input file exists beside the study

    def config(self) -> dict:
        return changed(BASE, self.where, self.value)

    def write(self, folder: Path) -> Path:
        """Put the case into ``folder``; the path to give as the study file."""
        path = folder / f"{self.name}.yaml"
        if self.engine_input:
            (folder / "in.data").write_text("fill\n")
        if self.path_kind == "directory":
            path.mkdir()
        elif self.path_kind == "file":
            path.write_bytes(
                self.raw
                if self.raw is not None
                else yaml.safe_dump(self.config(), sort_keys=False).encode()
            )
        return path


def _field(name: str, where: list, value, message: str, **extra) -> BadInput:
    return BadInput(name, message, where, value, **extra)


def _yaml(name: str, text: str | bytes, message: str) -> BadInput:
    return BadInput(name, message, raw=text if isinstance(text, bytes) else text.encode())


def _command(template: str, **settings) -> dict:
    return {"name": "command", "command": template, "responses_file": "r.json", **settings}


def _alias_bomb(levels: int = 9, width: int = 9, mapping: bool = False) -> str:
    """A few hundred bytes of nested YAML aliases that expand to width**levels values."""
    if mapping:
        lines = ["m0: &m0 {" + ", ".join(f"k{j}: lol" for j in range(width)) + "}"]
        lines += [
            f"m{i}: &m{i} {{" + ", ".join(f"k{j}: *m{i - 1}" for j in range(width)) + "}"
            for i in range(1, levels + 1)
        ]
    else:
        lines = ["a0: &a0 [" + ", ".join(["lol"] * width) + "]"]
        lines += [
            f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]" for i in range(1, levels + 1)
        ]
    return "study: bomb\n" + "\n".join(lines) + "\n"


def _base_yaml(extra: str = "") -> str:
    return yaml.safe_dump(BASE, sort_keys=False) + extra


#: Config cases: wrong values of a field, each refused with its own message.
FIELDS = [
    _field("unknown_field", ["colour"], "red", r"colour: unknown field; allowed here: .*engine"),
    _field(
        "misspelt_field",
        ["paramters"],
        {"sliding_friction_pp": {"lower": 0.1, "upper": 0.9}},
        r"paramters: unknown field; did you mean parameters\?$",
    ),
    _field(
        "misspelt_optimizer_field",
        ["optimizer", "max_evaluation"],
        5,
        r"optimizer.max_evaluation: unknown field; did you mean max_evaluations\?$",
    ),
    _field(
        "spread_as_percentage",
        ["targets", 0, "spread"],
        "3%",
        r"targets\[0\].spread: '3%' is text, not a number \(number\); a percentage is not "
        r"read: give the number in the field's unit",
    ),
    _field("no_targets", ["targets"], KeyError, r"missing required field 'targets'"),
    _field("study_name_escapes", ["study"], "../escape", r"study: '../escape' is not a valid name"),
    _field(
        "unknown_engine",
        ["engine", "name"],
        "dem2000",
        r"engine.name: 'dem2000' is not one of lammps, analytic, command",
    ),
    _field(
        "parameter_not_read",
        ["parameters", "stiffness"],
        {"lower": 1, "upper": 2},
        r"parameters.stiffness: not a parameter of the scenes cylinder_lift; they read",
    ),
    _field(
        "bounds_reversed",
        ["parameters", "sliding_friction_pp"],
        {"lower": 0.9, "upper": 0.1},
        r"parameters.sliding_friction_pp: lower bound 0.9 must be less than upper bound 0.1",
    ),
    _field(
        "bound_unphysical",
        ["parameters", "rolling_friction_pp"],
        {"lower": 0.1, "upper": 3.0},
        r"parameters.rolling_friction_pp.upper: 3 is outside the physically allowed range \[0, 1\]",
    ),
    _field(
        "parameter_unit",
        ["parameters", "sliding_friction_pp", "unit"],
        "deg",
        r"parameters.sliding_friction_pp.unit: 'deg' but demcal uses SI units",
    ),
    _field(
        "fixed_and_free",
        ["fixed", "sliding_friction_pp"],
        0.5,
        r"fixed.sliding_friction_pp: sliding_friction_pp is also a free parameter",
    ),
    _field(
        "fixed_unphysical",
        ["fixed", "youngs_modulus"],
        -1.0,
        r"fixed.youngs_modulus: -1 is outside the physically allowed range \[100000, 1e\+12\] Pa",
    ),
    _field(
        "response_of_other_scene",
        ["targets", 0, "response"],
        "shear_angle",
        r"targets\[0\].response: scene 'cylinder_lift' cannot produce 'shear_angle'",
    ),
    _field(
        "unknown_scene",
        ["targets", 0, "scene"],
        "drop_test",
        r"targets\[0\].scene: 'drop_test' is not a known scene",
    ),
    _field(
        "negative_weight", ["targets", 1, "weight"], -1.0, r"targets\[1\].weight: -1.0 must be > 0"
    ),
    _field(
        "target_unit",
        ["targets", 0, "unit"],
        "km",
        r"targets\[0\].unit: 'km' but angle_of_repose is measured in deg; give the value in "
        r"deg or in one of .*rad",
    ),
    _field(
        "timestep_too_large",
        ["timestep_fraction"],
        0.75,
        r"timestep_fraction: 0.75 is above 0.5 of the Rayleigh time",
    ),
    _field("no_replicates", ["replicates"], 0, r"replicates: 0 must be >= 1"),
    _field(
        "termination_rule",
        ["optimizer", "early_termination"],
        {"rule": "fast"},
        r"optimizer.early_termination.rule: 'fast' is not one of weighed, eq_3_4",
    ),
    _field(
        "staging_unknown",
        ["staging"],
        "serial",
        r"staging: 'serial' is not allowed; give one of auto, staged, parallel or a list",
    ),
    _field(
        "staging_scene",
        ["staging"],
        ["cylinder_lift", "hopper"],
        r"staging: \['cylinder_lift', 'hopper'\] must name each of the study's scenes once "
        r"\(cylinder_lift\); 'hopper' is not one of them",
    ),
    _field(
        "setting_misspelt",
        ["scenes"],
        {"cylinder_lift": {"settings": {"lift_sped": 0.01}}},
        r"scenes.cylinder_lift.settings.lift_sped: unknown setting for scene 'cylinder_lift'",
    ),
    _field(
        "setting_negative",
        ["scenes"],
        {"cylinder_lift": {"settings": {"lift_speed": -0.01}}},
        r"scenes.cylinder_lift.settings.lift_speed: -0.01 is outside the allowed range",
    ),
    _field(
        "cylinder_too_narrow",
        ["scenes"],
        {"cylinder_lift": {"settings": {"cylinder_diameter": 0.005}}},
        r"scenes.cylinder_lift.settings.cylinder_diameter: 0.005 m is less than 6 of the largest",
    ),
    _field(
        "setting_choice",
        ["scenes"],
        {"cylinder_lift": {"settings": {"aor_method": "eyeball"}}},
        r"scenes.cylinder_lift.settings.aor_method: 'eyeball' is not allowed; use one of flank_fit",
    ),
    _field(
        "executable_missing",
        ["engine"],
        _command("no-such-simulator -in {input}"),
        r"engine.command: executable 'no-such-simulator' not found",
    ),
    _field(
        "executable_path_missing",
        ["engine"],
        _command("/opt/no/such-simulator {seed}"),
        r"engine.command: executable '/opt/no/such-simulator' not found",
    ),
    _field(
        "unknown_placeholder",
        ["engine"],
        _command("python3 sim.py {friction}"),
        r"engine.command: unknown placeholder \{friction\}",
    ),
    *[
        _field(
            f"placeholder_format_{i}",
            ["engine"],
            _command(f"python3 sim.py {word}"),
            r"engine.command: .*placeholders are plain names",
        )
        for i, word in enumerate(
            ("{}", "{seed:d}", "{seed:>300000}", "{seed!r}", "{seed[0]}", "{seed.real}")
        )
    ],
    _field(
        "unbalanced_brace",
        ["engine"],
        _command("python3 sim.py {seed"),
        r"engine.command: '\{seed': .*write a literal brace as \{\{",
    ),
    _field(
        "input_without_file",
        ["engine"],
        _command("python3 sim.py {input}"),
        r"engine.command: \{input\} needs engine.input",
    ),
    _field(
        "input_file_missing",
        ["engine"],
        _command("python3 sim.py {input}", input="none.data"),
        r"engine.input: file 'none.data' not found",
    ),
    _field("negative_duration", ["engine", "duration"], -2, r"engine.duration: -2 must be >= 0"),
    _field(
        "failure_on_unknown_parameter",
        ["engine", "failures"],
        [{"when": {"density": [0, 1]}}],
        r"engine.failures\[0\].when.density: not a parameter of the study's scenes",
    ),
    _field(
        "repeats_overflow",
        ["targets", 0],
        {"scene": "cylinder_lift", "response": "angle_of_repose", "repeats": [1.7e308, 1.7e308]},
        r"targets\[0\]: 1.7e\+308 deg is not a possible angle_of_repose; it lies in \[0, 90\] deg",
    ),
    _field(
        "repeats_spread_overflows",
        ["targets", 0],
        {"scene": "cylinder_lift", "response": "angle_of_repose", "repeats": [1.7e308, -1.7e308]},
        r"targets\[0\].repeats: their standard deviation is beyond the largest float",
    ),
    _field(
        "repeats_one",
        ["targets", 0],
        {"scene": "cylinder_lift", "response": "angle_of_repose", "repeats": [25.0]},
        r"targets\[0\].repeats: 1 given; give at least 2",
    ),
    _field(
        "tests_with_repeats",
        ["targets", 0],
        {"scene": "cylinder_lift", "response": "angle_of_repose", "repeats": [24, 26], "tests": 2},
        r"targets\[0\].tests: given together with repeats, which determine it",
    ),
    _field(
        "tests_without_spread",
        ["targets", 0, "tests"],
        3,
        r"targets\[0\].tests: 3 tests of what scatter\? give the spread of single tests too",
    ),
    _field("no_tests", ["targets", 0, "tests"], 0, r"targets\[0\].tests: 0 must be >= 1"),
    _field(
        "negative_discrepancy",
        ["targets", 0, "discrepancy"],
        -1.0,
        r"targets\[0\].discrepancy: -1.0 must be >= 0",
    ),
    _field(
        "impossible_angle",
        ["targets", 0, "value"],
        95.0,
        r"targets\[0\].value: 95 deg is not a possible angle_of_repose",
    ),
    _field(
        "negative_density",
        ["targets", 1, "value"],
        -1400.0,
        r"targets\[1\].value: -1400 kg/m\^3 is not a possible bulk_density",
    ),
    _field(
        "quoted_workers",
        ["calibration"],
        {"workers": "2"},
        r"calibration.workers: '2' is text, not a number \(integer\); write it without quotes",
    ),
    _field(
        "quoted_value",
        ["targets", 0, "value"],
        "25",
        r"targets\[0\].value: '25' is text, not a number",
    ),
    _field(
        "quoted_bound",
        ["parameters", "sliding_friction_pp", "lower"],
        "0.1",
        r"parameters.sliding_friction_pp.lower: '0.1' is text, not a number",
    ),
    _field("quoted_seed", ["seed"], "3", r"seed: '3' is text, not a number"),
    _field("quoted_replicates", ["replicates"], "2", r"replicates: '2' is text, not a number"),
    _field(
        "quoted_fixed",
        ["fixed", "restitution_pp"],
        "0.5",
        r"fixed.restitution_pp: '0.5' is text, not a number",
    ),
    _field("no_parameters", ["parameters"], {}, r"parameters: none given; give at least 1"),
    _field("empty_targets", ["targets"], [], r"targets: none given; give at least 1"),
    *(
        _field(
            f"archive_url_{scheme}",
            ["archive"],
            {"url": f"{scheme}://host/archive"},
            rf"archive.url: {scheme}:// is not a database demcal can keep an archive in",
        )
        for scheme in ("http", "file")
    ),
]

#: YAML's .nan and .inf pass JSON Schema's range checks; every field refuses them by name.
NON_FINITE = [
    _field(
        "nan_value",
        ["targets", 0, "value"],
        float("nan"),
        r"targets\[0\].value: nan is not a finite number",
    ),
    _field(
        "inf_weight",
        ["targets", 1, "weight"],
        float("inf"),
        r"targets\[1\].weight: inf is not a finite number",
    ),
    _field(
        "nan_spread",
        ["targets", 1, "spread"],
        float("nan"),
        r"targets\[1\].spread: nan is not a finite number",
    ),
    _field(
        "inf_bound",
        ["parameters", "sliding_friction_pp", "upper"],
        float("inf"),
        r"parameters.sliding_friction_pp.upper: inf is not a finite number",
    ),
    _field(
        "minus_inf_fixed",
        ["fixed", "restitution_pp"],
        float("-inf"),
        r"fixed.restitution_pp: -inf is not a finite number",
    ),
    _field(
        "nan_timestep",
        ["timestep_fraction"],
        float("nan"),
        r"timestep_fraction: nan is not a finite number",
    ),
    _field(
        "nan_poll",
        ["calibration"],
        {"poll_seconds": float("nan")},
        r"calibration.poll_seconds: nan is not a finite",
    ),
    _field(
        "inf_budget_time",
        ["optimizer"],
        {"max_seconds": float("inf")},
        r"optimizer.max_seconds: inf is not a finite",
    ),
    _field(
        "nan_setting",
        ["scenes"],
        {"cylinder_lift": {"settings": {"lift_speed": float("nan")}}},
        r"scenes.cylinder_lift.settings.lift_speed: nan is not a finite",
    ),
    _field(
        "nan_timeout",
        ["engine"],
        _command("python3 s.py", timeout=float("nan")),
        r"engine.timeout: nan is not a finite number",
    ),
    _field(
        "overflowing_noise",
        ["engine"],
        {"name": "analytic", "noise": float("inf")},
        r"engine.noise: inf is not a finite number",
    ),
    _field(
        "material_of_no_calibration",
        ["material"],
        "never-calibrated",
        r"material: 'never-calibrated' names no calibration with an answer",
    ),
    _field("material_empty", ["material"], "", r"material: '' should be non-empty"),
    _field(
        "material_robust_not_a_flag",
        ["material"],
        {"calibration": "lab", "robust": "yes"},
        r"material.robust: 'yes' is not of type boolean",
    ),
]

#: The command engine deletes responses_file before each run: no path may leave the run directory.
ESCAPING_PATHS = [
    "/tmp/demcal-victim.json",
    "../../params.json",
    "../../../../tmp/x",
    "out/../../x.json",
    "simulation.json",
    "partial.csv",
    "",
    "out/",
]
ESCAPING = [
    _field(
        f"{key}_{i}",
        ["engine"],
        {**_command("python3 sim.py"), "responses_file": "out.json", key: path},
        rf"engine\.{key}: '{re.escape(path)}' ",
    )
    for key in ("responses_file", "partial_file")
    for i, path in enumerate(ESCAPING_PATHS)
]

#: Files that are not a readable study: refused naming the file.
FILES = [
    BadInput(
        "not_utf8", r"not_utf8.yaml: not UTF-8 text", raw="study: m\u00fcller\n".encode("latin-1")
    ),
    BadInput(
        "a_directory",
        r"a_directory.yaml is a directory; give the study's YAML file",
        path_kind="directory",
    ),
    BadInput(
        "missing_file", r"configuration file not found: .*missing_file.yaml", path_kind="missing"
    ),
    _yaml("alias_bomb", _alias_bomb(), r"alias_bomb.yaml: its YAML aliases expand to more than"),
    _yaml(
        "alias_bomb_mapping",
        _alias_bomb(mapping=True),
        r"alias_bomb_mapping.yaml: its YAML aliases expand to more than",
    ),
    _yaml(
        "recursive_alias",
        "study: &s [*s]\n",
        r"recursive_alias.yaml: a YAML alias refers to the node that contains it",
    ),
    _yaml(
        "too_large",
        _base_yaml("# " + "x" * 1_100_000 + "\n"),
        r"too_large.yaml: larger than 1000 kB",
    ),
    _yaml(
        "nested_too_deep",
        "study: " + "[" * 5000 + "]" * 5000 + "\n",
        r"nested_too_deep.yaml: nested too deeply",
    ),
    _yaml(
        "duplicate_key",
        "study: a\nseed: 1\nreplicates: 2\nseed: 3\n",
        r"duplicate_key.yaml: duplicate key 'seed' \(line 4\)",
    ),
    _yaml("not_yaml", "study: [unclosed\n", r"not_yaml.yaml: not valid YAML at line 2, column 1: "),
    _yaml(
        "tab_indented",
        "study: a\nengine:\n\tname: analytic\n",
        r"tab_indented.yaml: not valid YAML at line 3, column 1: found character '\\t'",
    ),
    _yaml("a_list", "- study: a\n", r"a_list.yaml: a study file is a YAML mapping"),
    _yaml("empty_file", "", r"empty_file.yaml: a study file is a YAML mapping"),
    _yaml(
        "reuse_of_an_unnamed_command",
        yaml.safe_dump(
            {**BASE, "engine": _command("python3 sim.py {seed}"), "reuse": "archive"},
            sort_keys=False,
        ),
        r"reuse: 'archive' needs engine.version: name the simulator's version",
    ),
    _yaml(
        "yte_template",
        "__use_yte__: true\n" + _base_yaml(),
        r"yte_template.yaml: __use_yte__: a study file is data, not a YTE template",
    ),
]

#: Every study-file case of the corpus.
CASES = FIELDS + NON_FINITE + ESCAPING + FILES


@dataclass(frozen=True)
class BadPoint:
    """A hand-written params.json (the README's "evaluate your own point"), and its reason."""

    name: str
    text: str
    reason: str


POINTS = [
    BadPoint(
        "point_nan",
        '{"parameters": {"sliding_friction_pp": NaN, "rolling_friction_pp": 0.1}}',
        r"sliding_friction_pp = nan is not a finite number",
    ),
    BadPoint(
        "point_text",
        '{"parameters": {"sliding_friction_pp": "0.4", "rolling_friction_pp": 0.1}}',
        r"sliding_friction_pp = '0.4' is not a number",
    ),
    BadPoint(
        "point_bool",
        '{"parameters": {"sliding_friction_pp": true, "rolling_friction_pp": 0.1}}',
        r"sliding_friction_pp = True is not a number",
    ),
    BadPoint(
        "point_missing",
        '{"parameters": {"sliding_friction_pp": 0.4}}',
        r"missing free parameters \['rolling_friction_pp'\]",
    ),
    BadPoint("point_not_json", '{"parameters": {"sliding_friction_pp": 0.4,', r"params.json"),
]


def write_point(folder: Path, point: BadPoint) -> tuple[Path, Path]:
    """A valid study and ``point`` as the params.json of evaluation
    ``point.name``: (study, target)."""
    study = folder / "study.yaml"
    study.write_text(yaml.safe_dump(BASE, sort_keys=False))
    evaluation = folder / "results" / BASE["study"] / "evals" / point.name
    evaluation.mkdir(parents=True)
    (evaluation / "params.json").write_text(point.text)
    return study, (evaluation / "objective.json").relative_to(folder)


def files_outside_results(folder: Path, given: Path) -> list[str]:
    """What a run left in ``folder`` besides the study file, ``results/`` and
    Snakemake's ``.snakemake/``."""
    left = []
    for path in folder.iterdir():
        if path.name in ("results", ".snakemake", given.name, "in.data"):
            continue
        left.append(path.name)
    return sorted(left)


def started_simulations(folder: Path) -> list[str]:
    """Evaluation folders a run created under ``results/`` (none for a refused study)."""
    return sorted(str(p.relative_to(folder)) for p in folder.glob("results/*/evals/*"))


#: The routes a user has to a study file: demcal's own command and the README's Snakemake one.
ROUTES = ("demcal run", "snakemake local", "snakemake slurm")
#: Seconds a route may take; a refused study takes about one.
ROUTE_TIMEOUT = 120


def route_command(
    route: str, study: Path, root: Path = ROOT, target: Path | None = None
) -> list[str]:
    """The command line of ``route`` for ``study`` (optionally one Snakemake target)."""
    if route == "demcal run":
        return [sys.executable, "-m", "demcal.cli", "run", str(study)]
    profile = route.split()[1]
    return [
        sys.executable,
        "-m",
        "snakemake",
        "-s",
        str(root / "Snakefile"),
        "--profile",
        str(root / "profiles" / profile),
        f"--configfile={study}",
        *([str(target)] if target else []),
    ]


@dataclass(frozen=True)
class Outcome:
    """What a route did with a bad input: exit code, the lines it printed, what it left."""

    returncode: int | None  # None: timed out
    lines: list[str]
    outside: list[str]
    started: list[str]

    def verdict(self, message: str) -> str:
        """clean (one line matching ``message``), or how it fell short (a bomb that is
        expanded times out)."""
        text = "\n".join(self.lines)
        if self.returncode is None:
            return "timed out"
        if self.returncode == 0 or self.started:
            return "wrongly accepted"
        if "Traceback" in text:
            return "traceback"
        if self.outside:
            return "wrote outside results/"
        if not self.lines:
            return "silent"
        if len(self.lines) > 1 or not self.lines[0].startswith("demcal: "):
            return "several lines"
        return "clean" if re.search(message, self.lines[0]) else "other message"


def run_route(
    route: str, case: BadInput, folder: Path, root: Path = ROOT, env: dict | None = None
) -> Outcome:
    """Give ``case`` to ``route`` in an empty ``folder``; what came of it."""
    folder.mkdir(parents=True)
    study = case.write(folder)
    try:
        done = subprocess.run(
            route_command(route, study, root),
            cwd=folder,
            capture_output=True,
            stdin=subprocess.DEVNULL,
            timeout=ROUTE_TIMEOUT,
            env=env,
        )
        returncode, output = done.returncode, done.stdout + done.stderr
    except subprocess.TimeoutExpired as exc:
        returncode, output = None, (exc.stdout or b"") + (exc.stderr or b"")
    output = output.decode(errors="replace")
    lines = [
        line
        for line in output.splitlines()
        if line.strip() and not line.startswith("Using profile ")
    ]
    return Outcome(
        returncode, lines, files_outside_results(folder, study), started_simulations(folder)
    )
