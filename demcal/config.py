"""Study configuration: schema validation, then checks against the scene declarations.

``load_study(config)`` turns the YAML mapping into a ``Study`` or raises
``ConfigError`` whose message names the field, the bad value and what is
allowed, before any simulation starts.
"""

from __future__ import annotations

import math
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import jsonschema
import numpy as np
import yaml

from demcal.engines import make_engine
from demcal.engines.base import Engine
from demcal.errors import ConfigError
from demcal.objective import Target
from demcal.optimizer import OptimizerSettings
from demcal.parameters import CATALOG, ParameterSpec
from demcal.scenes import SCENES, Scene
from demcal.timestep import RAYLEIGH_PARAMETERS, check_fraction, rayleigh_cost, rayleigh_time_range

SCHEMA_PATH = Path(__file__).resolve().parents[1] / "workflow" / "schemas" / "config.schema.yaml"


@dataclass(frozen=True)
class FreeParameter:
    """A parameter the optimizer varies between ``lower`` and ``upper`` (SI units)."""

    spec: ParameterSpec
    lower: float
    upper: float

    @property
    def name(self) -> str:
        return self.spec.name


@dataclass
class Study:
    name: str
    engine: Engine
    scenes: dict[str, Scene]
    settings: dict[str, dict]
    free: list[FreeParameter]
    fixed: dict[str, float]
    targets: list[Target]
    replicates: int
    seed: int
    timestep_fraction: float
    optimizer: OptimizerSettings
    #: W_RL of the Rayleigh time-step cost term (Rackl & Hanley 2017, eq. 10); 0 = off.
    rayleigh_cost_weight: float = 0.0
    calibration: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def results_dir(self) -> Path:
        return Path("results") / self.name

    def responses_needed(self, scene: str) -> list[str]:
        """Responses of ``scene`` that some target asks for, in declaration order."""
        wanted = {t.response for t in self.targets if t.scene == scene}
        return [r for r in self.scenes[scene].responses if r in wanted]

    def centre_point(self, overrides: list[str] = ()) -> dict[str, float]:
        """Free values at the centre of the bounds, changed by ``NAME=VALUE`` overrides."""
        point = {p.name: 0.5 * (p.lower + p.upper) for p in self.free}
        for item in overrides:
            name, _, value = item.partition("=")
            if name not in point:
                raise ConfigError(f"--point {item}: {name!r} is not a free parameter "
                                  f"({', '.join(point)})")
            try:
                point[name] = float(value)
            except ValueError:
                raise ConfigError(f"--point {item}: {value!r} is not a number") from None
        return point

    def timestep_cost(self, free_values: dict[str, float]) -> float:
        """Squared Rayleigh time-step cost of a point, added to its objective (0 when off)."""
        if self.rayleigh_cost_weight == 0.0:
            return 0.0
        bounds = {name: (self.fixed[name], self.fixed[name]) for name in RAYLEIGH_PARAMETERS
                  if name in self.fixed}
        bounds.update({p.name: (p.lower, p.upper) for p in self.free})
        term = rayleigh_cost(self.parameters_for(free_values), rayleigh_time_range(bounds),
                             self.rayleigh_cost_weight)
        return term * term

    def parameters_for(self, free_values: dict[str, float]) -> dict[str, float]:
        """All parameters of a point: the fixed ones overlaid with the free values (checked)."""
        missing = [p.name for p in self.free if p.name not in free_values]
        unknown = sorted(set(free_values) - {p.name for p in self.free})
        if missing or unknown:
            raise ConfigError(f"params.json: missing free parameters {missing}, "
                              f"unknown {unknown}; free parameters are "
                              f"{[p.name for p in self.free]}")
        for p in self.free:
            value = free_values[p.name]
            if not isinstance(value, (int, float)) or not math.isfinite(value) or not (
                    p.spec.lower <= value <= p.spec.upper):
                raise ConfigError(f"params.json: {p.name} = {value!r} is outside the allowed "
                                  f"range {p.spec.allowed()}")
        return {**self.fixed, **{k: float(v) for k, v in free_values.items()}}

    def simulation_seed(self, evaluation: str, scene: str, replicate: int, attempt: int = 0) -> int:
        """Seed of one simulation, from the study seed, evaluation, scene, replicate and attempt.

        Different replicates, evaluations and retries get independent streams;
        the same simulation always gets the same seed (reproducible reruns).
        """
        key = [self.seed, zlib.crc32(evaluation.encode()), zlib.crc32(scene.encode()), replicate]
        if attempt:
            key.append(attempt)
        return int(np.random.SeedSequence(key).generate_state(1)[0] % 2_147_483_646) + 1


def _field_path(error: jsonschema.ValidationError) -> str:
    parts = []
    for item in error.absolute_path:
        parts.append(f"[{item}]" if isinstance(item, int) else f".{item}")
    return "".join(parts).lstrip(".") or "(top level)"


def _schema_message(error: jsonschema.ValidationError, schema: dict) -> str:
    """One clear sentence for a schema violation: field, value, what is allowed."""
    where, value, kind = _field_path(error), error.instance, error.validator
    if kind == "additionalProperties":
        allowed = sorted(error.schema.get("properties", {}))
        extra = sorted(set(value) - set(allowed)) if isinstance(value, dict) else []
        name = f"{where}.{extra[0]}" if where != "(top level)" and extra else (extra or [where])[0]
        return f"{name}: unknown field; allowed here: {', '.join(allowed) or 'none'}"
    if kind == "required":
        return f"{where}: missing required field {error.message.split(' ')[0]}"
    if kind in ("enum", "const"):
        choices = error.validator_value if kind == "enum" else [error.validator_value]
        return f"{where}: {value!r} is not one of {', '.join(map(str, choices))}"
    if kind == "pattern":
        return (f"{where}: {value!r} is not a valid name (letters, digits, '_' and '-', "
                f"starting with a letter)")
    if kind in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
        words = {"minimum": ">=", "maximum": "<=", "exclusiveMinimum": ">",
                 "exclusiveMaximum": "<"}
        return f"{where}: {value!r} must be {words[kind]} {error.validator_value}"
    if kind == "type":
        return f"{where}: {value!r} is not of type {error.validator_value}"
    return f"{where}: {error.message}"


def load_schema() -> dict:
    return yaml.safe_load(SCHEMA_PATH.read_text())


def validate_schema(config: dict) -> None:
    schema = load_schema()
    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(config))
    if error is not None:
        raise ConfigError(_schema_message(error, schema))


def _scenes_of(config: dict) -> dict[str, Scene]:
    names = [t["scene"] for t in config["targets"]]
    for i, name in enumerate(names):
        if name not in SCENES:
            raise ConfigError(f"targets[{i}].scene: {name!r} is not a known scene; "
                              f"known scenes: {', '.join(sorted(SCENES))}")
    for name in config.get("scenes", {}):
        if name not in names:
            raise ConfigError(f"scenes.{name}: settings given for a scene no target uses; "
                              f"targeted scenes: {', '.join(sorted(set(names)))}")
    return {name: SCENES[name] for name in dict.fromkeys(names)}


def _targets(config: dict, scenes: dict[str, Scene]) -> list[Target]:
    targets, seen = [], set()
    for i, t in enumerate(config["targets"]):
        scene = scenes[t["scene"]]
        if t["response"] not in scene.responses:
            raise ConfigError(f"targets[{i}].response: scene {scene.name!r} cannot produce "
                              f"{t['response']!r}; it produces "
                              f"{', '.join(scene.responses)}")
        unit = scene.responses[t["response"]].unit
        if "unit" in t and t["unit"] != unit:
            raise ConfigError(f"targets[{i}].unit: {t['unit']!r} but {t['response']} is "
                              f"measured in {unit}; give the value in {unit}")
        key = (t["scene"], t["response"])
        if key in seen:
            raise ConfigError(f"targets[{i}]: {t['scene']}.{t['response']} is targeted twice")
        seen.add(key)
        targets.append(Target(t["scene"], t["response"], float(t["value"]),
                              float(t.get("weight", 1.0)), t.get("spread")))
    return targets


def _parameters(config: dict, scenes: dict[str, Scene]) -> tuple[list[FreeParameter], dict]:
    readable = sorted({p for s in scenes.values() for p in s.parameters})
    free = []
    for name, bounds in config["parameters"].items():
        where = f"parameters.{name}"
        if name not in readable:
            raise ConfigError(f"{where}: not a parameter of the scenes "
                              f"{', '.join(scenes)}; they read {', '.join(readable)}")
        spec = CATALOG[name]
        if "unit" in bounds and bounds["unit"] != spec.unit:
            raise ConfigError(f"{where}.unit: {bounds['unit']!r} but demcal uses SI units: "
                              f"give {name} in {spec.unit}")
        lower, upper = float(bounds["lower"]), float(bounds["upper"])
        if not lower < upper:
            raise ConfigError(f"{where}: lower bound {lower:g} must be less than upper "
                              f"bound {upper:g}")
        for side, value in (("lower", lower), ("upper", upper)):
            if not spec.contains(value):
                raise ConfigError(f"{where}.{side}: {value:g} is outside the physically "
                                  f"allowed range {spec.allowed()}")
        free.append(FreeParameter(spec, lower, upper))
    fixed = {}
    for name, value in config.get("fixed", {}).items():
        where = f"fixed.{name}"
        if name not in readable:
            raise ConfigError(f"{where}: not a parameter of the scenes "
                              f"{', '.join(scenes)}; they read {', '.join(readable)}")
        if name in config["parameters"]:
            raise ConfigError(f"{where}: {name} is also a free parameter; "
                              f"list it under parameters or fixed, not both")
        if not CATALOG[name].contains(value):
            raise ConfigError(f"{where}: {value:g} is outside the physically allowed range "
                              f"{CATALOG[name].allowed()}")
        fixed[name] = float(value)
    defaults = {n: CATALOG[n].default for n in readable
                if n not in fixed and n not in config["parameters"]}
    return free, {**defaults, **fixed}


_YAML12_FLOAT = re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?$")


def yaml12_numbers(value):
    """Read strings such as '5.0e6' as numbers.

    PyYAML follows YAML 1.1, where an exponent needs a sign and a dot
    (5.0e+6), so 5e6 arrives as text; YAML 1.2 and users read it as a number.
    """
    if isinstance(value, dict):
        return {k: yaml12_numbers(v) for k, v in value.items()}
    if isinstance(value, list):
        return [yaml12_numbers(v) for v in value]
    if isinstance(value, str) and _YAML12_FLOAT.match(value):
        return float(value)
    return value


def refuse_non_finite(value, where: str = "") -> None:
    """Raise ConfigError naming the first NaN or infinite number in a config mapping.

    JSON Schema's range checks compare with NaN as false, so ``.nan`` would
    pass every ``minimum``; no setting of a study means anything as NaN or
    infinity.
    """
    if isinstance(value, dict):
        for key, item in value.items():
            refuse_non_finite(item, f"{where}.{key}" if where else str(key))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            refuse_non_finite(item, f"{where}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{where or '(top level)'}: {value} is not a finite number; "
                          f"give a finite value")


def load_study(config: dict, check_engine: bool = True) -> Study:
    """Validate a study configuration (mapping from YAML) and resolve it into a ``Study``."""
    if not isinstance(config, dict):
        raise ConfigError("the configuration must be a mapping of fields (YAML object)")
    config = yaml12_numbers(config)
    refuse_non_finite(config)
    validate_schema(config)
    scenes = _scenes_of(config)
    targets = _targets(config, scenes)
    free, fixed = _parameters(config, scenes)
    settings = {name: scene.resolve_settings(config.get("scenes", {}).get(name, {}).get("settings"),
                                             f"scenes.{name}.settings")
                for name, scene in scenes.items()}
    fraction = float(config.get("timestep_fraction", 0.25))
    warning = check_fraction(fraction)
    cost_weight = float(config.get("rayleigh_cost_weight", 0.0))
    if cost_weight > 0.0 and not {p.name for p in free} & set(RAYLEIGH_PARAMETERS):
        raise ConfigError(
            f"rayleigh_cost_weight: {cost_weight:g} needs one of "
            f"{', '.join(RAYLEIGH_PARAMETERS)} among the free parameters (the Rayleigh time "
            f"step depends only on them); set it to 0 or free one of them")
    try:
        optimizer = OptimizerSettings.from_dict(config.get("optimizer", {}))
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    engine_config = dict(config["engine"])
    engine = make_engine(engine_config.pop("name"), engine_config)
    if check_engine:
        engine.check(list(scenes.values()))
    return Study(name=config["study"], engine=engine, scenes=scenes, settings=settings,
                 free=free, fixed=fixed, targets=targets,
                 replicates=int(config.get("replicates", 1)), seed=int(config.get("seed", 1)),
                 timestep_fraction=fraction, optimizer=optimizer,
                 rayleigh_cost_weight=cost_weight,
                 calibration={"retries": 1, "poll_seconds": 2.0,
                              **config.get("calibration", {})},
                 warnings=[warning] if warning else [])


def load_study_file(path: str | Path, check_engine: bool = True) -> Study:
    """Read a YAML study file and validate it."""
    try:
        config = yaml.safe_load(Path(path).read_text())
    except FileNotFoundError:
        raise ConfigError(f"configuration file not found: {path}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    return load_study(config, check_engine)
