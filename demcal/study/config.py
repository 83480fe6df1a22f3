"""Study configuration: schema validation, then checks against the scene declarations.

``load_study(config)`` turns the YAML mapping into a ``Study`` or raises
``ConfigError`` whose message names the field, the bad value and what is
allowed, before any simulation starts.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import replace
from pathlib import Path
from typing import Any

from demcal.engines import make_engine
from demcal.engines.base import Engine
from demcal.errors import ConfigError
from demcal.optimizer import OptimizerSettings
from demcal.optimizer.objective import DEFAULT_FORM, PRECISION
from demcal.optimizer.registry import STRATEGIES
from demcal.physics.catalogue import CATALOG, SPLIT_PARAMETERS
from demcal.physics.timestep import ADHESION_PARAMETERS, RAYLEIGH_PARAMETERS, check_fraction
from demcal.results.archive_url import check_url
from demcal.results.records import FINE
from demcal.scenes import SCENES, Scene
from demcal.scenes.base import variable_settings
from demcal.study.fidelity import fidelity_levels, given_settings
from demcal.study.material import with_material
from demcal.study.model import NEIGHBOURS, FidelityLevel, FreeParameter, Study
from demcal.study.schema import default, load_schema, validate_schema
from demcal.study.study_file import read_study_yaml
from demcal.study.targets import targets_of

#: The strategy that can spend a cheaper fidelity level (``optimizer.fidelity``).
SEARCH_WITH_LEVELS = "response_ei"


def _scenes_of(config: dict[str, Any]) -> dict[str, Scene]:
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


def _parameters(
    config: dict[str, Any], scenes: dict[str, Scene]
) -> tuple[list[FreeParameter], dict[str, float]]:
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


def _settings(
    given: dict[str, dict[str, Any]],
    scenes: dict[str, Scene],
    free: list[FreeParameter],
    prefix: str = "scenes",
) -> dict[str, dict[str, Any]]:
    """Each scene's resolved settings from those ``given`` per scene (fields named
    ``<prefix>.<scene>.settings``). A free setting is not given among them (its default
    stands in); the scene's cross-setting checks hold at every corner of the free settings'
    bounds, so no point the optimizer may propose is refused later."""
    resolved = {}
    for name, scene in scenes.items():
        where = f"{prefix}.{name}.settings"
        varied = [p for p in free if p.spec.scene_setting and p.name in scene.settings]
        for p in varied:
            if p.name in given[name]:
                raise ConfigError(
                    f"{where}.{p.name}: {p.name} is free (parameters.{p.name}); "
                    f"remove it here or from parameters"
                )
        resolved[name] = scene.resolve_settings(given[name], where)
        for corner in itertools.product(*[(p.lower, p.upper) for p in varied]):
            values = {p.name: value for p, value in zip(varied, corner)}
            try:
                scene.resolve_settings({**given[name], **values}, where)
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


def _archive(config: dict[str, Any]) -> str | None:
    """The URL of the study's archive (``archive: {url: ...}``, checked); None for
    ``archive: false``, the schema's default when the study names none or gives true."""
    value = config.get("archive", True)
    if value is False:
        return None
    url = default("archive")["url"] if value is True else value["url"]
    return check_url(url, "archive.url")


def _reuse(
    config: dict[str, Any], archive: str | None, engine: Engine, optimizer: OptimizerSettings
) -> str | None:
    """``reuse: archive`` or ``neighbours`` (None when off, the default); it needs an archive
    to read and an engine whose simulator demcal can tell apart from others; neighbouring
    materials teach the response models, so they need the search that uses them
    (response_ei) and, for now, no cheaper level."""
    reuse = config.get("reuse", default("reuse")) or None
    if reuse is None:
        return None
    if archive is None:
        raise ConfigError(
            f"reuse: {reuse!r} reads the study's archive, but it has none (archive: false); "
            "name one (archive: {url: ...}) or set reuse: false"
        )
    problem = engine.reuse_problem()
    if problem is not None:
        raise ConfigError(f"reuse: {reuse!r} needs {problem}")
    if reuse == NEIGHBOURS and optimizer.strategy != SEARCH_WITH_LEVELS:
        raise ConfigError(
            f"reuse: {NEIGHBOURS!r} teaches the response models, which the "
            f"{optimizer.strategy} strategy does not search with; use strategy: "
            f"{SEARCH_WITH_LEVELS}, or reuse: archive"
        )
    if reuse == NEIGHBOURS and optimizer.fidelity is not None:
        raise ConfigError(
            f"reuse: {NEIGHBOURS!r} cannot be combined with optimizer.fidelity yet (the "
            "multi-fidelity models take no material inputs); use reuse: archive, or drop "
            "optimizer.fidelity"
        )
    return str(reuse)


def _staging(
    config: dict[str, Any], scenes: dict[str, Scene], optimizer: OptimizerSettings
) -> tuple[str, ...] | None:
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
    time: Rackl & Hanley 2017, eq. 9; adhesion): each point then runs with its own time step."""
    return [
        f"parameters.{p.name}: the time step (timestep_fraction of the Rayleigh time) depends "
        f"on it, so each point runs with its own time step: a stiffer or lighter point needs "
        f"more steps (rayleigh_cost_weight can penalise them)"
        for p in free
        if p.name in RAYLEIGH_PARAMETERS and engine.steps_in_time
    ] + [
        f"parameters.{p.name}: adhesion can shorten the time step (to a tenth of an adhesive "
        f"contact's duration), so each point may run with its own time step: a more cohesive "
        f"point may need more steps"
        for p in free
        if p.name in ADHESION_PARAMETERS and engine.steps_in_time
    ]


def _check_modelled(engine: Engine, free: list[FreeParameter], fixed: dict[str, float]) -> None:
    """Refuse a parameter the engine's drivers do not model at a value other than its
    catalogue default (free, or fixed away from it)."""
    for name in engine.UNMODELLED_PARAMETERS:
        default = CATALOG[name].default
        is_free = name in {p.name for p in free}
        if is_free or fixed.get(name, default) != default:
            raise ConfigError(
                f"{'parameters' if is_free else 'fixed'}.{name}: engine {engine.name} does not "
                f"model it; fix it at {default:g} or use engine lammps"
            )


def _check_search_level(optimizer: OptimizerSettings, levels: dict[str, FidelityLevel]) -> None:
    """``optimizer.fidelity`` must name a cheaper level of the study, and the search must model
    the responses (response_ei), which the multi-fidelity models are."""
    name = optimizer.fidelity
    if name is None:
        return
    if name not in levels:
        have = f"its levels are {', '.join(levels)}" if levels else "it declares none"
        raise ConfigError(
            f"optimizer.fidelity: {name!r} is not a cheaper level of the study ({have}); "
            f"declare it under fidelities: (docs/fidelity.md)"
        )
    if optimizer.strategy != SEARCH_WITH_LEVELS:
        raise ConfigError(
            f"optimizer.fidelity: the {optimizer.strategy} strategy cannot spend a cheaper "
            f"level; use strategy: {SEARCH_WITH_LEVELS} (its multi-fidelity response models)"
        )


def load_study(config: dict[str, Any], check_engine: bool = True) -> Study:
    """Validate a study configuration (mapping from YAML) and resolve it into a ``Study``."""
    if not isinstance(config, dict):
        raise ConfigError("the configuration must be a mapping of fields (YAML object)")
    refuse_non_finite(config)
    validate_schema(config)
    scenes = _scenes_of(config)
    targets, conversions = targets_of(config, scenes)
    config, material, material_draws, material_warnings = with_material(config, scenes)
    free, fixed = _parameters(config, scenes)
    settings = _settings(given_settings(config, scenes), scenes, free)
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
        form = DEFAULT_FORM if unspread else PRECISION
    if form == PRECISION and unspread:
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
    _check_modelled(engine, free, fixed)
    optimizer, skipped = _without_estimates(optimizer, engine)
    levels, level_warnings = fidelity_levels(
        config,
        scenes,
        free,
        FidelityLevel(FINE, settings, fraction, engine),
        lambda given, prefix: _settings(given, scenes, free, prefix),
    )
    for level in levels.values():
        if check_engine:
            level.engine.check(list(scenes.values()))
        _check_modelled(level.engine, free, fixed)
    _check_search_level(optimizer, levels)
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
            *level_warnings,
        ],
        archive=archive,
        reuse=_reuse(config, archive, engine, optimizer),
        material=material,
        material_draws=material_draws,
        fidelities=levels,
    )


def load_study_file(path: str | Path, check_engine: bool = True) -> Study:
    """Read a YAML study file and validate it."""
    return load_study(read_study_yaml(path), check_engine)
