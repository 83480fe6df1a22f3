"""Study configuration: schema validation, then checks against the scene declarations.

``load_study(config)`` turns the YAML mapping into a ``Study`` or raises
``ConfigError`` whose message names the field, the bad value and what is
allowed, before any simulation starts.
"""

from __future__ import annotations

import itertools
import math
import re
import statistics
from collections.abc import Hashable
from dataclasses import replace
from pathlib import Path
from typing import Any

import yaml

from demcal.engines import make_engine
from demcal.engines.base import Engine
from demcal.errors import ConfigError
from demcal.optimizer import OptimizerSettings
from demcal.optimizer.objective import DEFAULT_FORM, Target
from demcal.optimizer.registry import STRATEGIES
from demcal.physics.catalogue import CATALOG, SPLIT_PARAMETERS
from demcal.physics.timestep import RAYLEIGH_PARAMETERS, check_fraction
from demcal.results.archive_url import check_url
from demcal.scenes import SCENES, ResponseSpec, Scene
from demcal.scenes.base import variable_settings
from demcal.study.material import CalibratedMaterial, load_material, load_robust_material
from demcal.study.model import FreeParameter, Study
from demcal.study.schema import default, load_schema, validate_schema
from demcal.study.units import CONVERSIONS, conversion_factor


def _scenes_of(config: dict) -> dict[str, Scene]:
    names = [t["scene"] for t in config["targets"]]
    for i, name in enumerate(names):
        if name not in SCENES:
            raise ConfigError(
                f"targets[{i}].scene: {name!r} is not a known scene; "
                f"known scenes: {', '.join(sorted(SCENES))}"
            )
    for name in config.get("scenes", {}):
        if name not in names:
            raise ConfigError(
                f"scenes.{name}: settings given for a scene no target uses; "
                f"targeted scenes: {', '.join(sorted(set(names)))}"
            )
    return {name: SCENES.load(name) for name in dict.fromkeys(names)}


#: The numbers of a target that are in its unit (``weight`` is not).
TARGET_QUANTITIES = ("value", "spread", "repeats", "at_least", "at_most")


def _in_response_unit(target: dict, index: int, unit: str) -> tuple[dict, str | None]:
    """``target`` with its numbers in ``unit``, its response's unit, and a note of the
    conversion or of a unit left out (None when neither); a ConfigError for a unit demcal
    cannot convert."""
    if "unit" not in target and unit != "-":
        return target, (
            f"targets[{index}]: no unit given; read as {unit}, the unit {target['response']} "
            f"is measured in"
        )
    given = target.get("unit", unit)
    factor = conversion_factor(given, unit)
    if factor is None:
        convertible = sorted(CONVERSIONS.get(unit, {}))
        raise ConfigError(
            f"targets[{index}].unit: {given!r} but {target['response']} is measured in {unit}; "
            f"give the value in {unit}"
            + (f" or in one of {', '.join(convertible)}" if convertible else "")
        )
    if factor == 1.0:
        return target, None
    converted = {
        key: [v * factor for v in value] if isinstance(value, list) else value * factor
        for key, value in target.items()
        if key in TARGET_QUANTITIES
    }
    shown = ", ".join(
        f"{key} {target[key]} {given} -> {_shown_number(converted[key])} {unit}"
        for key in converted
    )
    return {**target, **converted, "unit": unit}, f"targets[{index}]: converted {shown}"


def _shown_number(value: float | list[float]) -> str:
    if isinstance(value, list):
        return f"[{', '.join(f'{v:.4g}' for v in value)}]"
    return f"{value:.4g}"


def _targets(config: dict, scenes: dict[str, Scene]) -> tuple[list[Target], list[str]]:
    """The study's targets in their responses' units, and a note of each conversion."""
    targets, seen, notes = [], set(), []
    for i, t in enumerate(config["targets"]):
        scene = scenes[t["scene"]]
        if t["response"] not in scene.responses:
            raise ConfigError(
                f"targets[{i}].response: scene {scene.name!r} cannot produce "
                f"{t['response']!r}; it produces "
                f"{', '.join(scene.responses)}"
            )
        unit = scene.responses[t["response"]].unit
        t, note = _in_response_unit(t, i, unit)
        notes += [note] if note else []
        key = (t["scene"], t["response"])
        if key in seen:
            raise ConfigError(f"targets[{i}]: {t['scene']}.{t['response']} is targeted twice")
        seen.add(key)
        response = scene.responses[t["response"]]
        lower, upper = _target_bounds(t, i, response)
        if lower is None and upper is None:
            value, spread = _target_value(t, i)
            where = f"targets[{i}]{'' if 'repeats' in t else '.value'}"
            _check_possible(value, where, t["response"], response)
        else:
            value = next(bound for bound in (lower, upper) if bound is not None)
            spread = t.get("spread")
        targets.append(
            Target(
                t["scene"],
                t["response"],
                value,
                float(t.get("weight", default("targets", "weight"))),
                spread,
                lower,
                upper,
            )
        )
    return targets, notes


def _check_possible(value: float, where: str, name: str, response: ResponseSpec) -> None:
    """ConfigError unless ``response`` (named ``name``) can take ``value`` (given at
    ``where``)."""
    if not response.lower <= value <= response.upper:
        raise ConfigError(
            f"{where}: {value:g} {response.unit} is not a possible {name}; it lies in "
            f"[{response.lower:g}, {response.upper:g}] {response.unit}"
        )


def _target_bounds(
    target: dict, index: int, response: ResponseSpec
) -> tuple[float | None, float | None]:
    """The bounds of a target given as ``at_least``/``at_most`` or as a ``goal`` (a target at
    the response's own bound); (None, None) for a target ``value`` or ``repeats``."""
    kinds = [
        name
        for name, keys in (
            ("value", ("value", "repeats")),
            ("bounds", ("at_least", "at_most")),
            ("goal", ("goal",)),
        )
        if any(k in target for k in keys)
    ]
    if len(kinds) > 1:
        raise ConfigError(
            f"targets[{index}]: give one of a value (value or repeats), bounds (at_least, "
            f"at_most) or a goal (minimise, maximise), not {' and '.join(kinds)}"
        )
    where = f"targets[{index}]"
    if "goal" in target:
        goal = response.lower if target["goal"] == "minimise" else response.upper
        if not math.isfinite(goal):
            raise ConfigError(
                f"{where}.goal: {target['response']} has no {'lowest' if goal < 0 else 'highest'}"
                f" possible value to {target['goal']} it towards; give a value to reach or bounds"
                f" (at_least, at_most)"
            )
        return (None, goal) if target["goal"] == "minimise" else (goal, None)
    lower, upper = target.get("at_least"), target.get("at_most")
    for name, bound in (("at_least", lower), ("at_most", upper)):
        if bound is not None:
            _check_possible(float(bound), f"{where}.{name}", target["response"], response)
    if lower is not None and upper is not None and not lower < upper:
        raise ConfigError(
            f"{where}.at_most: {upper:g} {response.unit} is not above at_least "
            f"({lower:g} {response.unit})"
        )
    return (
        None if lower is None else float(lower),
        None if upper is None else float(upper),
    )


def _target_value(target: dict, index: int) -> tuple[float, float | None]:
    """The target's value and spread: as given, or the mean and standard
    deviation of its repeats."""
    if "repeats" not in target:
        if "value" not in target:
            raise ConfigError(
                f"targets[{index}]: give the measured value (value: ..., optionally "
                f"spread: ...) or the lab test's repeats (repeats: [..., ...])"
            )
        return float(target["value"]), target.get("spread")
    given = [key for key in ("value", "spread") if key in target]
    if given:
        raise ConfigError(
            f"targets[{index}].{given[0]}: given together with repeats, which "
            f"determine it (their mean and standard deviation); give one or the other"
        )
    repeats = target["repeats"]
    try:  # exact arithmetic: a float sum of large repeats would overflow where their mean does not
        value, spread = float(statistics.mean(repeats)), float(statistics.stdev(repeats))
    except OverflowError:
        value, spread = math.inf, math.inf
    if not math.isfinite(spread):
        raise ConfigError(
            f"targets[{index}].repeats: their standard deviation is beyond the "
            f"largest float ({max(repeats, key=abs):g} among them); give the repeats "
            f"in the response's unit"
        )
    return value, spread


def _check_readable(where: str, name: str, known: list[str], scenes: dict[str, Scene]) -> None:
    """Raise ConfigError unless ``name`` (given at ``where``) is among the ``known`` names of
    what the scenes read."""
    if name in SPLIT_PARAMETERS:
        parts = SPLIT_PARAMETERS[name]
        raise ConfigError(
            f"{where}: demcal now has {' and '.join(parts)} (particle-particle and "
            f"particle-wall) in place of {name}; give both, e.g. "
            f"{parts[0]}: 0.5 and {parts[1]}: 0.5 for the one value of before"
        )
    if name not in known:
        raise ConfigError(
            f"{where}: not a parameter of the scenes {', '.join(scenes)}; "
            f"they read {', '.join(known)}"
        )


def _parameters(config: dict, scenes: dict[str, Scene]) -> tuple[list[FreeParameter], dict]:
    """The free parameters, material or scene setting (bounds checked), and every material
    parameter's fixed value (given, else the catalogue's default)."""
    readable = sorted({p for s in scenes.values() for p in s.parameters})
    variable = variable_settings(scenes.values())
    free = []
    for name, bounds in config["parameters"].items():
        where = f"parameters.{name}"
        _check_readable(where, name, readable + sorted(variable), scenes)
        spec = variable.get(name) or CATALOG[name]
        if "unit" in bounds and bounds["unit"] != spec.unit:
            raise ConfigError(
                f"{where}.unit: {bounds['unit']!r} but demcal uses SI units: "
                f"give {name} in {spec.unit}"
            )
        lower, upper = float(bounds["lower"]), float(bounds["upper"])
        if not lower < upper:
            raise ConfigError(
                f"{where}: lower bound {lower:g} must be less than upper bound {upper:g}"
            )
        for side, value in (("lower", lower), ("upper", upper)):
            if not spec.contains(value):
                raise ConfigError(
                    f"{where}.{side}: {value:g} is outside the physically "
                    f"allowed range {spec.allowed()}"
                )
        free.append(FreeParameter(spec, lower, upper))
    fixed = {}
    for name, value in config.get("fixed", {}).items():
        where = f"fixed.{name}"
        if name in variable:
            raise ConfigError(
                f"{where}: {name} is a scene setting; give its value under "
                f"scenes.<scene>.settings, or bounds under parameters to make it free"
            )
        _check_readable(where, name, readable, scenes)
        if name in config["parameters"]:
            raise ConfigError(
                f"{where}: {name} is also a free parameter; "
                f"list it under parameters or fixed, not both"
            )
        if not CATALOG[name].contains(value):
            raise ConfigError(
                f"{where}: {value:g} is outside the physically allowed range "
                f"{CATALOG[name].allowed()}"
            )
        fixed[name] = float(value)
    defaults = {
        n: CATALOG[n].default for n in readable if n not in fixed and n not in config["parameters"]
    }
    return free, {**defaults, **fixed}


def _with_material(
    config: dict, scenes: dict[str, Scene]
) -> tuple[dict, dict | None, tuple[dict[str, float], ...], list[str]]:
    """The study file with the calibrated material (``material:``) filled in wherever the
    file neither fixes nor frees a value; the material's provenance; with ``robust``, the
    materials drawn for the replicates (the values this study takes from the calibration);
    and warnings for each calibrated value the file replaces and each parameter the
    calibration did not have."""
    if "material" not in config:
        return config, None, (), []
    material = _load_material(config)
    free, warnings = config["parameters"], []
    fixed = dict(config.get("fixed", {}))
    source = f"the calibration {material.study!r}"
    if material.engine != config["engine"]["name"]:
        warnings.append(
            f"material: {source} simulated with {material.engine}, this study with "
            f"{config['engine']['name']}; their contact models differ, so its values may not "
            f"carry over"
        )
    for name in sorted({p for s in scenes.values() for p in s.parameters} - set(free)):
        if name not in material.parameters:
            if name not in fixed:
                warnings.append(
                    f"material: {source} did not simulate with {name}; its default "
                    f"{CATALOG[name].default:g} is used (give it under fixed)"
                )
        elif name in fixed:
            if fixed[name] != material.parameters[name]:
                warnings.append(
                    f"fixed.{name} = {fixed[name]:g} replaces {material.parameters[name]:g} "
                    f"of {source}"
                )
        else:
            fixed[name] = material.parameters[name]
    taken = set(fixed) - set(config.get("fixed", {}))
    draws = tuple({k: v for k, v in draw.items() if k in taken} for draw in material.draws)
    scene_config = {
        name: {**entry, "settings": dict(entry.get("settings") or {})}
        for name, entry in config.get("scenes", {}).items()
    }
    for setting, value in material.settings.items():
        for name in (n for n, scene in scenes.items() if setting in scene.settings):
            given = scene_config.setdefault(name, {"settings": {}})["settings"]
            if setting in free:
                continue
            if setting not in given:
                given[setting] = value
            elif given[setting] != value:
                warnings.append(
                    f"scenes.{name}.settings.{setting} = {given[setting]:g} replaces "
                    f"{value:g} of {source}"
                )
    return (
        {**config, "fixed": fixed, "scenes": scene_config},
        material.provenance(),
        draws,
        warnings,
    )


def _without_estimates(
    optimizer: OptimizerSettings, engine: Engine
) -> tuple[OptimizerSettings, list[str]]:
    """The optimizer's settings with early termination off, and a note saying so, where the
    engine gives no early estimate to judge (replicates then run side by side, not staged)."""
    if not optimizer.early_termination.enabled or engine.gives_estimates():
        return optimizer, []
    off = replace(optimizer.early_termination, enabled=False)
    return replace(optimizer, early_termination=off), [
        f"optimizer.early_termination: skipped, as the {engine.name} engine gives no early "
        f"estimate of a response (no engine.partial_file); every simulation runs to its end"
    ]


def _load_material(config: dict) -> CalibratedMaterial:
    """The calibration ``material:`` names (a reference, or ``{calibration, robust}``)."""
    spec = config["material"]
    if isinstance(spec, str):
        return load_material(spec)
    if not spec.get("robust", False):
        return load_material(spec["calibration"])
    replicates = int(config.get("replicates", default("replicates")))
    if replicates < 2:
        raise ConfigError(
            f"replicates: {replicates}; material.robust draws one material from the "
            f"calibration's solution set per replicate, so it needs replicates >= 2"
        )
    seed = int(config.get("seed", default("seed")))
    return load_robust_material(spec["calibration"], replicates, seed)


def _settings(config: dict, scenes: dict[str, Scene], free: list[FreeParameter]) -> dict:
    """Each scene's resolved settings. A free setting is not given among them (its default
    stands in); the scene's cross-setting checks hold at every corner of the free settings'
    bounds, so no point the optimizer may propose is refused later."""
    resolved = {}
    for name, scene in scenes.items():
        where = f"scenes.{name}.settings"
        given = config.get("scenes", {}).get(name, {}).get("settings") or {}
        varied = [p for p in free if p.spec.scene_setting and p.name in scene.settings]
        for p in varied:
            if p.name in given:
                raise ConfigError(
                    f"{where}.{p.name}: {p.name} is free (parameters.{p.name}); "
                    f"remove it here or from parameters"
                )
        resolved[name] = scene.resolve_settings(given, where)
        for corner in itertools.product(*[(p.lower, p.upper) for p in varied]):
            values = {p.name: value for p, value in zip(varied, corner)}
            try:
                scene.resolve_settings({**given, **values}, where)
            except ConfigError as exc:
                at = ", ".join(f"{n} = {v:g}" for n, v in values.items())
                raise ConfigError(f"{exc} (at {at}, a corner of the free bounds)") from None
    return resolved


def check_study_name(name: str, where: str) -> str:
    """``name`` if the schema allows it as a study's name, else a ConfigError naming ``where``."""
    identifier = load_schema()["$defs"]["identifier"]
    if len(name) > identifier["maxLength"] or not re.fullmatch(identifier["pattern"], name):
        raise ConfigError(
            f"{where} {name!r}: not a study name (a letter, then letters, digits, '_' and '-'; "
            f"at most {identifier['maxLength']} characters)"
        )
    return name


def refuse_non_finite(value: object, where: str = "") -> None:
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
        raise ConfigError(
            f"{where or '(top level)'}: {value} is not a finite number; give a finite value"
        )


def _archive(config: dict) -> str | None:
    """The URL of the study's archive (``archive: {url: ...}``, checked); None for
    ``archive: false``, the schema's default when the study names none or gives true."""
    value = config.get("archive", True)
    if value is False:
        return None
    url = default("archive")["url"] if value is True else value["url"]
    return check_url(url, "archive.url")


def _reuse(config: dict, archive: str | None, engine: Engine) -> str | None:
    """``reuse: archive`` (None when off, the default); it needs an archive to read and an
    engine whose simulator demcal can tell apart from others."""
    reuse = config.get("reuse", default("reuse")) or None
    if reuse is not None and archive is None:
        raise ConfigError(
            "reuse: 'archive' reads the study's archive, but it has none (archive: false); "
            "name one (archive: {url: ...}) or set reuse: false"
        )
    problem = engine.reuse_problem()
    if reuse is not None and problem is not None:
        raise ConfigError(f"reuse: 'archive' needs {problem}")
    return reuse


def _staging(config: dict, scenes: dict, optimizer: OptimizerSettings) -> tuple[str, ...] | None:
    """``Study.staging`` from the study's ``staging``: None (parallel), () (replicate 0 of
    the scenes first, together) or the scenes in the order their replicate 0 runs."""
    staging = config.get("staging", default("staging"))
    if isinstance(staging, list):
        if sorted(staging) != sorted(scenes):
            unknown = [name for name in staging if name not in scenes]
            raise ConfigError(
                f"staging: {staging} must name each of the study's scenes once "
                f"({', '.join(scenes)})"
                + (f"; {', '.join(map(repr, unknown))} is not one of them" if unknown else "")
            )
        return tuple(staging)
    stops_early = optimizer.early_termination.enabled and STRATEGIES[optimizer.strategy].stops_early
    return () if staging == "staged" or (staging == "auto" and stops_early) else None


def _timestep_notes(free: list[FreeParameter], engine: Engine) -> list[str]:
    """A note for each free parameter the time step depends on (a fraction of the Rayleigh
    time: Rackl & Hanley 2017, eq. 9): each point then runs with its own time step."""
    return [
        f"parameters.{p.name}: the time step (timestep_fraction of the Rayleigh time) depends "
        f"on it, so each point runs with its own time step: a stiffer or lighter point needs "
        f"more steps (rayleigh_cost_weight can penalise them)"
        for p in free
        if p.name in RAYLEIGH_PARAMETERS and engine.steps_in_time
    ]


def load_study(config: dict, check_engine: bool = True) -> Study:
    """Validate a study configuration (mapping from YAML) and resolve it into a ``Study``."""
    if not isinstance(config, dict):
        raise ConfigError("the configuration must be a mapping of fields (YAML object)")
    refuse_non_finite(config)
    validate_schema(config)
    scenes = _scenes_of(config)
    targets, conversions = _targets(config, scenes)
    config, material, material_draws, material_warnings = _with_material(config, scenes)
    free, fixed = _parameters(config, scenes)
    settings = _settings(config, scenes, free)
    fraction = float(config.get("timestep_fraction", default("timestep_fraction")))
    warning = check_fraction(fraction, default("timestep_fraction"))
    cost_weight = float(config.get("rayleigh_cost_weight", default("rayleigh_cost_weight")))
    if cost_weight > 0.0 and not {p.name for p in free} & set(RAYLEIGH_PARAMETERS):
        raise ConfigError(
            f"rayleigh_cost_weight: {cost_weight:g} needs one of "
            f"{', '.join(RAYLEIGH_PARAMETERS)} among the free parameters (the Rayleigh time "
            f"step depends only on them); set it to 0 or free one of them"
        )
    form = config.get("objective", default("objective"))
    unspread = [i for i, t in enumerate(targets) if not t.spread]
    if form == "auto":  # weigh each error by its measurement spread when every spread is known
        form = DEFAULT_FORM if unspread else "precision"
    if form == "precision" and unspread:
        raise ConfigError(
            f"targets[{unspread[0]}].spread: the precision-weighted objective "
            f"measures each error in units of its target's spread; give every "
            f"target a spread > 0 (its measurement standard deviation), or use "
            f"objective: relative"
        )
    # The response models model neither the Rayleigh cost term nor the expected loss over
    # drawn materials: with either, a study's default is the optimizer's own (dycors), and
    # the strategies on response models are refused.
    values_only = (
        f"rayleigh_cost_weight {cost_weight:g}"
        if cost_weight > 0.0
        else "material.robust (the loss over the drawn materials)"
        if material_draws
        else ""
    )
    strategy = OptimizerSettings().strategy if values_only else default("optimizer", "strategy")
    try:
        optimizer = OptimizerSettings.from_dict(
            {"strategy": strategy, **config.get("optimizer", {})}
        )
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    if values_only and STRATEGIES[optimizer.strategy].needs_targets:
        raise ConfigError(
            f"optimizer.strategy: {optimizer.strategy} models the responses, which does not "
            f"capture {values_only}; use dycors or kriging_ei"
        )
    archive = _archive(config)
    engine_config = dict(config["engine"])
    engine = make_engine(engine_config.pop("name"), engine_config)
    if check_engine:
        engine.check(list(scenes.values()))
    optimizer, skipped = _without_estimates(optimizer, engine)
    return Study(
        name=config["study"],
        engine=engine,
        scenes=scenes,
        settings=settings,
        free=free,
        fixed=fixed,
        targets=targets,
        replicates=int(config.get("replicates", default("replicates"))),
        staging=_staging(config, scenes, optimizer),
        seed=int(config.get("seed", default("seed"))),
        timestep_fraction=fraction,
        optimizer=optimizer,
        objective_form=form,
        rayleigh_cost_weight=cost_weight,
        calibration={
            "retries": default("calibration", "retries"),
            "poll_seconds": default("calibration", "poll_seconds"),
            **config.get("calibration", {}),
        },
        warnings=[
            *([warning] if warning else []),
            *conversions,
            *material_warnings,
            *skipped,
            *_timestep_notes(free, engine),
        ],
        archive=archive,
        reuse=_reuse(config, archive, engine),
        material=material,
        material_draws=material_draws,
    )


#: Largest study file demcal reads (bytes); a study is a few hundred lines.
MAX_STUDY_FILE_BYTES = 1_000_000
#: Most values a study file may hold once its YAML aliases are expanded.
MAX_STUDY_VALUES = 100_000


class StrictLoader(yaml.SafeLoader):
    """YAML's safe loader, strict where a study file needs it.

    A key given twice in one mapping is refused (YAML keeps the last), and
    plain scalars such as 5e6 are numbers as in YAML 1.2 (PyYAML follows
    YAML 1.1, where an exponent needs a dot and a sign); quoted text stays text.
    """

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Hashable, Any]:
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise ConfigError(
                    f"duplicate key {key!r} (line {key_node.start_mark.line + 1}): "
                    f"YAML would silently keep only the last one; remove one"
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def expanded_size(node: yaml.Node, limit: int) -> int:
    """Values in a composed YAML document with every alias expanded, counted up to ``limit``.

    Aliases share their node, so composing costs nothing; a few hundred bytes
    of nested aliases (a "billion laughs" file) would expand into billions of
    values when the study is read, and a node that contains itself forever.
    """
    sizes: dict[int, int] = {}

    def size(item: yaml.Node, inside: frozenset) -> int:
        if id(item) in sizes:
            return sizes[id(item)]
        if id(item) in inside:
            raise ConfigError("a YAML alias refers to the node that contains it")
        children = (
            [part for pair in item.value for part in pair]
            if isinstance(item, yaml.MappingNode)
            else item.value
            if isinstance(item, yaml.SequenceNode)
            else []
        )
        total = 1
        for child in children:
            total += size(child, inside | {id(item)})
            if total > limit:
                break
        sizes[id(item)] = total
        return total

    return size(node, frozenset())


def _yaml_problem(error: yaml.YAMLError) -> str:
    """PyYAML's several-line message as one clause: where, then what."""
    mark = getattr(error, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
    problem = getattr(error, "problem", None) or str(error)
    return f"{where}: {' '.join(problem.split())}"


def read_study_yaml(path: str | Path) -> dict:
    """The mapping of a YAML study file, read strictly; every problem is a
    ConfigError naming the file."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            raw = stream.read(MAX_STUDY_FILE_BYTES + 1)
        if len(raw) > MAX_STUDY_FILE_BYTES:
            raise ConfigError(
                f"larger than {MAX_STUDY_FILE_BYTES // 1000} kB; a study file is a "
                f"few hundred lines of YAML"
            )
        loader = StrictLoader(raw.decode("utf-8"))
        try:
            document = loader.get_single_node()
            if (
                document is not None
                and expanded_size(document, MAX_STUDY_VALUES) > MAX_STUDY_VALUES
            ):
                raise ConfigError(
                    f"its YAML aliases expand to more than {MAX_STUDY_VALUES} values "
                    f"(nested aliases, a 'billion laughs' file?); write the study "
                    f"out without them"
                )
            config = loader.construct_document(document) if document is not None else None
        finally:
            loader.dispose()
    except FileNotFoundError:
        raise ConfigError(f"configuration file not found: {path}") from None
    except IsADirectoryError:
        raise ConfigError(f"{path} is a directory; give the study's YAML file") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except (
        OSError
    ) as exc:  # permission denied, an I/O error: the Snakefile too prints it in one line
        raise ConfigError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML{_yaml_problem(exc)}") from None
    except RecursionError:
        raise ConfigError(f"{path}: nested too deeply to be a study file") from None
    if not isinstance(config, dict):
        raise ConfigError(
            f"{path}: a study file is a YAML mapping (study:, engine:, parameters:, ...)"
        )
    if "__use_yte__" in config:  # refused before Snakemake would render it (and run its code)
        raise ConfigError(
            f"{path}: __use_yte__: a study file is data, not a YTE template "
            f"(whose Python expressions Snakemake would run); write the values out"
        )
    return config


def load_study_file(path: str | Path, check_engine: bool = True) -> Study:
    """Read a YAML study file and validate it."""
    return load_study(read_study_yaml(path), check_engine)
