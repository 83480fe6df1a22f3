"""A study's fidelity levels (``fidelities:``): cheaper simulations of the same lab tests.

Each level is a name with overrides of each scene's settings, of the time-step fraction and of
the engine's settings; what it does not override is the study's own (the fine level, named
:data:`~demcal.results.records.FINE`). ``default`` takes every scene's documented default
coarse level (``Scene.coarse``: fewer, larger particles of the same amount of material, or a
smaller shear box). A level is checked like the study's own settings, with its fields named
``fidelities.<level>....``; one that simulates exactly what the fine level does is refused.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

from demcal.engines import make_engine
from demcal.engines.base import Engine
from demcal.errors import ConfigError
from demcal.physics.timestep import check_fraction
from demcal.results.records import FINE
from demcal.scenes import Scene
from demcal.study.model import FidelityLevel, FreeParameter
from demcal.study.schema import default, validate_schema

#: How a study asks for every scene's default coarse level.
DEFAULT_LEVEL = "default"

#: (scene settings given per scene, where) -> each scene's resolved settings; the study's own
#: settings check (free settings, cross-setting checks at the corners of their bounds).
SettingsCheck = Callable[[dict[str, dict[str, Any]], str], dict[str, dict[str, Any]]]


def given_settings(config: dict[str, Any], scenes: dict[str, Scene]) -> dict[str, dict[str, Any]]:
    """The settings the study file gives each scene (``scenes.<name>.settings``)."""
    return {
        name: dict(config.get("scenes", {}).get(name, {}).get("settings") or {}) for name in scenes
    }


def fidelity_levels(
    config: dict[str, Any],
    scenes: dict[str, Scene],
    free: list[FreeParameter],
    fine: FidelityLevel,
    resolve: SettingsCheck,
) -> tuple[dict[str, FidelityLevel], list[str]]:
    """The study's cheaper levels by name, each resolved and checked, and the warnings of
    their time-step fractions. ``fine`` is the study's own level, ``resolve`` its settings
    check."""
    levels, warnings = {}, []
    own = given_settings(config, scenes)
    for name, given in (config.get("fidelities") or {}).items():
        where = f"fidelities.{name}"
        if name == FINE:
            raise ConfigError(
                f"{where}: '{FINE}' names the study's own settings; give the level another name"
            )
        overrides = (
            _default_overrides(scenes, free, fine, where)
            if given == DEFAULT_LEVEL
            else _given_overrides(given, scenes, where)
        )
        settings = resolve(
            {scene: {**own[scene], **overrides.get(scene, {})} for scene in scenes},
            f"{where}.scenes",
        )
        fraction = fine.timestep_fraction
        if isinstance(given, dict) and "timestep_fraction" in given:
            fraction = float(given["timestep_fraction"])
            warning = check_fraction(
                fraction, default("timestep_fraction"), f"{where}.timestep_fraction"
            )
            warnings += [warning] if warning else []
        engine = _engine(config, given.get("engine", {}) if isinstance(given, dict) else {}, where)
        level = FidelityLevel(name, settings, fraction, engine)
        if _same_simulations(level, fine):
            raise ConfigError(
                f"{where}: simulates exactly what the study's own settings do (the fine level); "
                f"change a scene's settings, the timestep_fraction or the engine's settings"
            )
        levels[name] = level
    return levels, warnings


def _default_overrides(
    scenes: dict[str, Scene], free: list[FreeParameter], fine: FidelityLevel, where: str
) -> dict[str, dict[str, Any]]:
    """Every scene's default coarse level (``Scene.coarse``) from its fine settings; a
    ConfigError when a scene has none or it changes a free setting."""
    overrides = {}
    free_names = {p.name for p in free}
    for name, scene in scenes.items():
        if scene.coarse is None:
            raise ConfigError(
                f"{where}: scene {name} has no default coarse level; give the level's "
                f"settings (fidelities.<level>.scenes.{name}.settings)"
            )
        changed = scene.coarse(fine.settings[name])
        clash = sorted(set(changed) & free_names)
        if clash:
            raise ConfigError(
                f"{where}: the default coarse level of {name} changes {', '.join(clash)}, "
                f"which the study frees; give the level's settings instead"
            )
        overrides[name] = changed
    return overrides


def _given_overrides(
    given: dict[str, Any], scenes: dict[str, Scene], where: str
) -> dict[str, dict[str, Any]]:
    """The scene settings a level gives, for scenes of the study only."""
    overrides = {}
    for name, scene_given in (given.get("scenes") or {}).items():
        if name not in scenes:
            raise ConfigError(
                f"{where}.scenes.{name}: not a scene of the study ({', '.join(scenes)})"
            )
        overrides[name] = dict(scene_given.get("settings") or {})
    return overrides


def _engine(config: dict[str, Any], overrides: dict[str, Any], where: str) -> Engine:
    """The study's engine with a level's settings over its own, checked by the schema as the
    study's ``engine`` is (errors name the level's field)."""
    if "name" in overrides:
        raise ConfigError(
            f"{where}.engine.name: a level runs on the study's engine "
            f"({config['engine']['name']}); leave the name out"
        )
    merged = {**config["engine"], **overrides}
    trial = {**copy.deepcopy(config), "engine": merged}
    trial.pop("fidelities", None)
    try:
        validate_schema(trial)
    except ConfigError as exc:
        message = str(exc)
        raise ConfigError(
            f"{where}.{message}" if message.startswith("engine") else f"{where}.engine: {message}"
        ) from None
    settings = dict(merged)
    return make_engine(settings.pop("name"), settings)


def _same_simulations(level: FidelityLevel, fine: FidelityLevel) -> bool:
    """Whether a level runs exactly the fine level's simulations."""
    return (
        level.settings == fine.settings
        and level.timestep_fraction == fine.timestep_fraction
        and level.engine.outcome() == fine.engine.outcome()
    )
