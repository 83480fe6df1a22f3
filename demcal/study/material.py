"""A study's material taken from a finished calibration (``material:`` in the study file).

A design study optimises a machine for a material that an earlier calibration
found: ``material: quickstart`` (a study name, read from ``results/quickstart/``)
or ``material: path/to/best.json``. The material is that calibration's best
point (``best.json``) over its fixed parameters (``study.json``): every
material parameter it simulated with, and the particle-size settings it
varied (``d50``, ``sigma_ln``). The values are filled in where the new study
gives none; what the new study fixes or frees itself wins. Where the values
came from is kept with the study (``Study.material``).

``material: {calibration: quickstart, robust: true}`` carries the
calibration's uncertainty into the design: replicate ``r`` of every
evaluation simulates with the ``r``-th of ``replicates`` materials drawn
from the calibration's likely solution set (``solutions.csv``, what its
targets cannot tell apart), and the evaluation's objective is the expected
loss over them (``ResponseObjective.expected_loss``).
"""

from __future__ import annotations

import hashlib
import re
import reprlib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from demcal.errors import ConfigError, SimulationFailed
from demcal.physics.catalogue import CATALOG, free_names, upgrade_parameters
from demcal.results.layout import STUDY_FILE, StudyFiles
from demcal.results.records import BestRecord
from demcal.results.storage import read_json
from demcal.scenes import Scene
from demcal.study.schema import default


@dataclass(frozen=True)
class CalibratedMaterial:
    """A calibration's answer as a material: its parameters and particle-size settings."""

    #: name of the calibration study, and the engine it simulated with
    study: str
    engine: str
    #: the best.json read, and a fingerprint of its content
    best_file: str
    best_sha256: str
    #: the evaluation that is the answer, and its objective
    evaluation: str
    objective: float
    #: whether the calibration had ended (finished.json), or its best so far was taken
    finished: bool
    #: every material parameter the answer was simulated with (SI units)
    parameters: dict[str, float]
    #: free scene settings of the calibration at its answer (particle size: d50 [m], ...)
    settings: dict[str, float]
    #: robust: materials drawn from the solution set, one per replicate (the calibration's
    #: free material parameters only), and the solutions.csv they came from with its SHA-256
    draws: list[dict[str, float]] = field(default_factory=list)
    solutions_file: str = ""
    solutions_sha256: str = ""

    def provenance(self) -> dict[str, Any]:
        """What ``study.json`` keeps of it."""
        return {
            "study": self.study,
            "engine": self.engine,
            "best": self.best_file,
            "best_sha256": self.best_sha256,
            "evaluation": self.evaluation,
            "objective": self.objective,
            "finished": self.finished,
            "parameters": self.parameters,
            "settings": self.settings,
            **(
                {
                    "solutions": self.solutions_file,
                    "solutions_sha256": self.solutions_sha256,
                    "draws": self.draws,
                }
                if self.draws
                else {}
            ),
        }


def calibration_folder(reference: str) -> tuple[Path, Path]:
    """The results folder and best.json that ``material:`` names: a study name
    (``results/<name>/best.json``), a study's results folder, or a best.json file."""
    path = Path(reference)
    if path.suffix == ".json":
        return path.parent, path
    if re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]*", reference) and not path.exists():
        files = StudyFiles.of(reference)
        return files.dir, files.best
    return path, StudyFiles(path).best


def load_material(reference: str) -> CalibratedMaterial:
    """The answer of the calibration that ``reference`` names; a ConfigError naming
    ``material`` when there is none to take."""
    folder, best_path = calibration_folder(reference)
    study_path = StudyFiles(folder).study
    try:
        best = BestRecord.read(best_path)
        fingerprint = hashlib.sha256(best_path.read_bytes()).hexdigest()
        calibration = read_json(study_path, STUDY_FILE)
        free = {p["name"]: bool(p.get("scene_setting")) for p in calibration["parameters"]}
        fixed = upgrade_parameters(calibration["fixed"], free_names(calibration["parameters"]))
        name, engine = str(calibration["study"]), str(calibration["engine"]["name"])
    except SimulationFailed as exc:
        raise ConfigError(
            f"material: {reference!r} names no calibration with an answer ({exc}); give a "
            f"study name whose calibration has run (results/<study>/best.json) or the path "
            f"of its best.json"
        ) from None
    except (KeyError, TypeError, AttributeError, OSError) as exc:
        raise ConfigError(
            f"material: {study_path} is not a study written by demcal ({type(exc).__name__}: {exc})"
        ) from None
    missing = sorted(set(free) - set(best.parameters))
    if missing:
        raise ConfigError(
            f"material: {best_path} gives no value of {', '.join(missing)}, free in the "
            f"calibration {name!r}; it belongs to another study"
        )
    parameters = {
        parameter: _number(value, study_path, f"fixed.{parameter}")
        for parameter, value in fixed.items()
    }
    settings = {}
    for parameter, is_setting in free.items():
        value = _number(best.parameters[parameter], best_path, f"parameters.{parameter}")
        if is_setting:
            settings[parameter] = value
        else:
            parameters[parameter] = value
    for parameter, value in parameters.items():
        if parameter not in CATALOG or not CATALOG[parameter].contains(value):
            raise ConfigError(
                f"material: {parameter} = {value!r} from {best_path} is not a material "
                f"parameter of this demcal in its allowed range"
            )
    return CalibratedMaterial(
        study=name,
        engine=engine,
        best_file=str(best_path),
        best_sha256=fingerprint,
        evaluation=best.evaluation,
        objective=float(best.objective),
        finished=StudyFiles(folder).finished.exists(),
        parameters=parameters,
        settings=settings,
    )


def _number(value: object, path: Path, key: str) -> float:
    """A value of the calibration's files as a number; a ConfigError naming the file and the
    field ``key`` when it is text, a list or anything else."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(
            f"material: {path}: {key} is {reprlib.repr(value)}, not a number; the file is "
            f"damaged or was not written by demcal"
        )
    return float(value)


def draw_materials(
    folder: Path, names: list[str], count: int, seed: int
) -> tuple[list[dict[str, float]], Path, str]:
    """``count`` materials drawn without replacement (seeded) from the likely part of the
    calibration's solution set in ``folder``: the values of ``names`` of each, the
    solutions.csv and its SHA-256. A ConfigError naming ``material`` if there are too few."""
    # imported here: pandas, and the SciPy that membership brings, are more than the
    # Snakefile's start (it loads every study's material) and a refused study should pay for
    import pandas as pd

    from demcal.optimizer.membership import LIKELY

    path = StudyFiles(folder).solutions
    try:
        table = pd.read_csv(path)
        likely = table[table["membership_probability"] >= LIKELY][names]
    except (OSError, KeyError, ValueError, pd.errors.ParserError) as exc:
        raise ConfigError(
            f"material.robust: no solution set of the calibration in {path} "
            f"({type(exc).__name__}: {exc}); run its report (demcal solutions CONFIG) first"
        ) from None
    if len(likely) < count:
        raise ConfigError(
            f"material.robust: the solution set in {path} has {len(likely)} likely points, "
            f"fewer than the {count} replicates to draw materials for; lower replicates"
        )
    rows = np.random.default_rng(seed).choice(len(likely), size=count, replace=False)
    draws = [{name: float(likely.iloc[i][name]) for name in names} for i in sorted(rows)]
    return draws, path, hashlib.sha256(path.read_bytes()).hexdigest()


def load_robust_material(reference: str, count: int, seed: int) -> CalibratedMaterial:
    """The calibration's answer (``load_material``) with ``count`` materials drawn from its
    solution set for the replicates (``draw_materials``)."""
    material = load_material(reference)
    folder, _ = calibration_folder(reference)
    names = sorted(set(material.parameters) & _free_material(folder))
    draws, path, fingerprint = draw_materials(folder, names, count, seed)
    return replace(material, draws=draws, solutions_file=str(path), solutions_sha256=fingerprint)


def _free_material(folder: Path) -> set[str]:
    """The material parameters the calibration in ``folder`` left free."""
    calibration = read_json(StudyFiles(folder).study, STUDY_FILE)
    return {p["name"] for p in calibration["parameters"] if not p.get("scene_setting")}


def with_material(
    config: dict[str, Any], scenes: dict[str, Scene]
) -> tuple[dict[str, Any], dict[str, Any] | None, tuple[dict[str, float], ...], list[str]]:
    """The study file with the calibrated material (``material:``) filled in wherever the
    file neither fixes nor frees a value; the material's provenance; with ``robust``, the
    materials drawn for the replicates (the values this study takes from the calibration);
    and warnings for each calibrated value the file replaces and each parameter the
    calibration did not have."""
    if "material" not in config:
        return config, None, (), []
    material = load_calibrated_material(config)
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


def load_calibrated_material(config: dict[str, Any]) -> CalibratedMaterial:
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
