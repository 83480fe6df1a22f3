"""The resolved study, and its frozen copy ``results/<study>/study.json``.

A study file is validated once (``demcal.study.config``) by whoever starts a
calibration; the resolved ``Study`` (every setting and default filled in) is
written to ``study.json``, and the daemon, its child Snakemakes and every job
read that file back (``load_frozen``) instead of the YAML, so an edit of the
YAML during a run cannot reach the running calibration. A YAML that differs
from an existing ``study.json`` is compared field by field (``freeze``):
budget, stopping rules, daemon settings and target values or weights may
change on resume; anything that would make stored simulations incomparable
is refused with the fields named.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from demcal.engines import make_engine
from demcal.engines.base import Engine
from demcal.errors import ConfigError, SimulationFailed
from demcal.optimizer import OptimizerSettings
from demcal.optimizer.objective import (
    DEFAULT_FORM,
    ResponseObjective,
    Target,
    band_terms_of,
    bounds_of,
)
from demcal.physics.catalogue import (
    CATALOG,
    SPLIT_PARAMETERS,
    ParameterSpec,
    free_names,
    upgrade_parameters,
)
from demcal.physics.timestep import RAYLEIGH_PARAMETERS, rayleigh_cost, rayleigh_time_range
from demcal.results.layout import STUDY_FILE, StudyFiles
from demcal.results.records import FINE
from demcal.results.storage import read_json, write_json_if_changed
from demcal.scenes import SCENES, Scene
from demcal.scenes.base import variable_settings
from demcal.study.schema import default

#: Optimizer settings a resumed calibration takes from the current study file.
RESUMABLE_OPTIMIZER_SETTINGS = (
    "max_evaluations",
    "max_seconds",
    "target_objective",
    "no_improvement_evaluations",
    "early_termination",
    "confirm_replicates",
    "map_solutions",
    "stop_when_known",
    "calm_share",
    "calm_proposals",
)
#: Target fields that may change on resume (stored simulations are re-scored).
RESCORABLE_TARGET_FIELDS = (
    "value",
    "weight",
    "spread",
    "unit",
    "lower",
    "upper",
    "tests",
    "discrepancy",
)


#: ``reuse:`` that also takes the archive's runs of neighbouring materials (docs/archive.md)
NEIGHBOURS = "neighbours"


@dataclass(frozen=True)
class FreeParameter:
    """A parameter the optimizer varies between ``lower`` and ``upper`` (SI units)."""

    spec: ParameterSpec
    lower: float
    upper: float

    @property
    def name(self) -> str:
        return self.spec.name


@dataclass(frozen=True)
class FidelityLevel:
    """A fidelity level: the settings of every scene and the time-step fraction a simulation
    runs with, and the engine that runs it. The study's own are the fine level (:data:`FINE`);
    ``fidelities:`` adds cheaper ones (coarser particles, a smaller test, a looser step)."""

    name: str
    settings: dict[str, dict[str, Any]]
    timestep_fraction: float
    engine: Engine


@dataclass
class Study:
    """A validated, fully resolved study: what every job of a calibration works from."""

    name: str
    engine: Engine
    scenes: dict[str, Scene]
    settings: dict[str, dict[str, Any]]
    free: list[FreeParameter]
    fixed: dict[str, float]
    targets: list[Target]
    replicates: int
    #: Which simulations of an evaluation wait for others (``jobs.steps.staged_inputs``):
    #: None, all at once; else replicate 0 of every scene first, each after the scene before
    #: it in this order (empty: together), and the other replicates after them.
    staging: tuple[str, ...] | None
    seed: int
    timestep_fraction: float
    optimizer: OptimizerSettings
    #: "relative" (eq. 3.3) or "precision" (errors in units of the targets' spreads)
    objective_form: str = DEFAULT_FORM
    #: W_RL of the Rayleigh time-step cost term (Rackl & Hanley 2017, eq. 10); 0 = off.
    rayleigh_cost_weight: float = 0.0
    calibration: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    #: URL of the archive every simulation is recorded in (demcal.archive); None: none
    archive: str | None = None
    #: "archive": start from the archive's compatible simulations (docs/archive.md);
    #: NEIGHBOURS: and from those of neighbouring materials; None: off
    reuse: str | None = None
    #: where the material came from when a calibration gave it (``CalibratedMaterial``)
    material: dict[str, Any] | None = None
    #: robust material: replicate r simulates with draw r over the fixed values, and the
    #: objective is the expected loss over the draws (docs/studies.md); empty: one material
    material_draws: tuple[dict[str, float], ...] = ()
    #: the cheaper fidelity levels by name (``fidelities:``; docs/fidelity.md); the study's
    #: own settings are the fine level
    fidelities: dict[str, FidelityLevel] = field(default_factory=dict)

    def level(self, name: str = FINE) -> FidelityLevel:
        """The fidelity level ``name``: the study's own settings for :data:`FINE`; a
        ConfigError for a name the study does not have."""
        if name == FINE:
            return FidelityLevel(FINE, self.settings, self.timestep_fraction, self.engine)
        if name not in self.fidelities:
            raise ConfigError(
                f"fidelity {name!r}: the study has no such level "
                f"({', '.join([FINE, *self.fidelities])})"
            )
        return self.fidelities[name]

    @property
    def levels(self) -> list[str]:
        """The names of the study's fidelity levels, fine first."""
        return [FINE, *self.fidelities]

    @property
    def objective(self) -> ResponseObjective:
        """The objective of this study's targets in its form (the one computation of it)."""
        return ResponseObjective(
            tuple(self.targets), self.objective_form, expected_loss=bool(self.material_draws)
        )

    @property
    def response_objective(self) -> ResponseObjective | None:
        """The objective the optimizer applies to responses; None with the Rayleigh cost term
        or drawn materials, which the response models do not model (the optimizer then works
        on values only)."""
        return None if self.rayleigh_cost_weight or self.material_draws else self.objective

    @property
    def files(self) -> StudyFiles:
        """Paths of this study's results (``results/<study>/``)."""
        return StudyFiles.of(self.name)

    @property
    def keeps_history(self) -> bool:
        """Whether a scene of the study keeps its responses over time (the report's figure of
        the answer over time)."""
        return any(scene.history is not None for scene in self.scenes.values())

    def responses_needed(self, scene: str) -> list[str]:
        """Responses of ``scene`` that some target asks for, in declaration order."""
        wanted = {t.response for t in self.targets if t.scene == scene}
        return [r for r in self.scenes[scene].responses if r in wanted]

    def centre_point(self, overrides: Sequence[str] = ()) -> dict[str, float]:
        """Free values at the centre of the bounds, changed by ``NAME=VALUE`` overrides."""
        point = {p.name: 0.5 * (p.lower + p.upper) for p in self.free}
        return {**point, **self.free_values(overrides, "--point")}

    def free_values(self, items: Sequence[str], option: str) -> dict[str, float]:
        """``NAME=VALUE`` words of a command line as free-parameter values (finite numbers,
        each parameter once); a ConfigError names ``option``, the word and what is wrong."""
        names = [p.name for p in self.free]
        values: dict[str, float] = {}
        for item in items:
            name, _, value = item.partition("=")
            if name not in names:
                raise ConfigError(
                    f"{option} {item}: {name!r} is not a free parameter ({', '.join(names)})"
                )
            if name in values:
                raise ConfigError(
                    f"{option} {item}: {name} is given twice ({name}={values[name]:g} before); "
                    f"give each free parameter once"
                )
            try:
                values[name] = float(value)
            except ValueError:
                raise ConfigError(f"{option} {item}: {value!r} is not a number") from None
            if not math.isfinite(values[name]):
                raise ConfigError(f"{option} {item}: {value!r} is not a finite number")
        return values

    def timestep_cost(self, free_values: dict[str, float]) -> float:
        """Squared Rayleigh time-step cost of a point, added to its objective (0 when off)."""
        if self.rayleigh_cost_weight == 0.0:
            return 0.0
        bounds = {
            name: (self.fixed[name], self.fixed[name])
            for name in RAYLEIGH_PARAMETERS
            if name in self.fixed
        }
        bounds.update({p.name: (p.lower, p.upper) for p in self.free})
        term = rayleigh_cost(
            self.parameters_for(free_values), rayleigh_time_range(bounds), self.rayleigh_cost_weight
        )
        return term * term

    def parameters_for(self, free_values: dict[str, float], replicate: int = 0) -> dict[str, float]:
        """The material parameters of a point's ``replicate``: the fixed ones, overlaid with
        that replicate's drawn material if any, then with the point's free material values;
        every free value, settings included, is checked."""
        missing = [p.name for p in self.free if p.name not in free_values]
        unknown = sorted(set(free_values) - {p.name for p in self.free})
        if missing or unknown:
            raise ConfigError(
                f"params.json: missing free parameters {missing}, "
                f"unknown {unknown}; free parameters are "
                f"{[p.name for p in self.free]}"
            )
        for p in self.free:
            value = free_values[p.name]
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(f"params.json: {p.name} = {value!r} is not a number")
            if not math.isfinite(value):
                raise ConfigError(f"params.json: {p.name} = {value} is not a finite number")
            if not p.spec.contains(value):
                raise ConfigError(
                    f"params.json: {p.name} = {value:g} is outside the allowed "
                    f"range {p.spec.allowed()}"
                )
        material = {p.name for p in self.free if not p.spec.scene_setting}
        drawn = (
            self.material_draws[replicate % len(self.material_draws)] if self.material_draws else {}
        )
        return {
            **self.fixed,
            **drawn,
            **{k: float(v) for k, v in free_values.items() if k in material},
        }

    def settings_for(
        self, scene: str, free_values: dict[str, float], fidelity: str = FINE
    ) -> dict[str, Any]:
        """The settings ``scene`` runs a point with at level ``fidelity``: its resolved settings
        overlaid with the point's values of the free settings it declares."""
        settings = self.level(fidelity).settings[scene]
        return {
            **settings,
            **{
                p.name: float(free_values[p.name])
                for p in self.free
                if p.spec.scene_setting and p.name in settings
            },
        }

    def archive_view(
        self, scene: str, fidelity: str = FINE
    ) -> tuple[dict[str, Any], dict[str, float], list[str]]:
        """What an archived simulation of ``scene`` must share with this study to serve its
        models: the settings that are not variable, the value of every fixed parameter and
        fixed variable setting, and the models' inputs (the free parameters the scene reads).
        The archive keeps variable settings as parameters (``demcal.archive.simulation``)."""
        variable = {n for n, spec in self.scenes[scene].settings.items() if spec.variable}
        free = {p.name for p in self.free}
        resolved = self.level(fidelity).settings[scene]
        settings = {n: v for n, v in resolved.items() if n not in variable}
        fixed = {**self.fixed, **{n: resolved[n] for n in sorted(variable - free)}}
        inputs = [p.name for p in self.free if not p.spec.scene_setting or p.name in variable]
        return settings, fixed, inputs

    def simulator(self, scene: str, fidelity: str = FINE) -> dict[str, Any]:
        """What simulated ``scene`` at level ``fidelity``, beyond the parameters, settings,
        seed and time step: the engine (name, version, the settings that change responses,
        the files a command reads) and the scene's script for it. Simulations are the same
        simulator's only if these agree (``reuse: archive`` and the global metamodels take no
        other)."""
        engine = self.level(fidelity).engine
        return {
            **engine.outcome(),
            "scene_script": self.scenes[scene].script_digests(engine.name),
        }

    def fine_level_view(self, scene: str) -> dict[str, Any]:
        """What identifies the fine level of ``scene`` in the archive, the level a coarse
        simulation belongs to: its settings (those not kept as parameters), time-step
        fraction and simulator."""
        settings, _, _ = self.archive_view(scene)
        return {
            "settings": settings,
            "timestep_fraction": self.timestep_fraction,
            "simulator": self.simulator(scene),
        }

    def simulation_seed(
        self,
        evaluation: str,
        scene: str,
        replicate: int,
        attempt: int = 0,
        avoid: Collection[int] = (),
    ) -> int:
        """Seed of one simulation, from the study seed, evaluation, scene, replicate and attempt.

        Different replicates, evaluations and retries get independent streams;
        the same simulation always gets the same seed (reproducible reruns). A seed in
        ``avoid`` (those of the simulations a study reused) moves on to the next stream: the
        key gets one more number, counted up until the seed is new.
        """
        key = [self.seed, zlib.crc32(evaluation.encode()), zlib.crc32(scene.encode()), replicate]
        if attempt:
            key.append(attempt)
        seed, skipped = _seed(key), 0
        while seed in avoid:
            skipped += 1
            seed = _seed([*key, attempt, skipped])
        return seed


def _seed(key: list[int]) -> int:
    """A seed in [1, 2**31 - 2] drawn from ``key``'s stream."""
    return int(np.random.SeedSequence(key).generate_state(1)[0] % 2_147_483_646) + 1


def demcal_version() -> str:
    try:
        return metadata.version("demcal")
    except metadata.PackageNotFoundError:
        return "unknown"


def study_record(study: Study) -> dict[str, Any]:
    """The resolved study as a JSON-able mapping (the content of ``study.json``)."""
    return {
        "demcal_version": demcal_version(),
        "study": study.name,
        "engine": {"name": study.engine.name, **study.engine.settings},
        # lists, not objects: the order of scenes and free parameters matters
        "scenes": [{"name": name, "settings": study.settings[name]} for name in study.scenes],
        "parameters": [
            {"name": p.name, "lower": p.lower, "upper": p.upper, "unit": p.spec.unit}
            | ({"scene_setting": True} if p.spec.scene_setting else {})
            for p in study.free
        ],
        "fixed": study.fixed,
        "targets": [
            {
                "scene": t.scene,
                "response": t.response,
                "value": t.value,
                "unit": study.scenes[t.scene].responses[t.response].unit,
                "weight": t.weight,
                "spread": t.spread,
                **bounds_of(t),
                **band_terms_of(t),
            }
            for t in study.targets
        ],
        "replicates": study.replicates,
        "staging": None if study.staging is None else list(study.staging),
        "seed": study.seed,
        "timestep_fraction": study.timestep_fraction,
        "rayleigh_cost_weight": study.rayleigh_cost_weight,
        "objective": study.objective_form,
        "optimizer": study.optimizer.to_dict(),
        "calibration": study.calibration,
        "warnings": study.warnings,
        "archive": {"url": study.archive},
        **({"reuse": study.reuse} if study.reuse else {}),
        **({"material": study.material} if study.material else {}),
        # compared on resume, unlike the material's provenance
        **({"drawn_materials": list(study.material_draws)} if study.material_draws else {}),
        **(
            {
                "fidelities": {
                    name: {
                        "scenes": level.settings,
                        "timestep_fraction": level.timestep_fraction,
                        "engine": {"name": level.engine.name, **level.engine.settings},
                    }
                    for name, level in study.fidelities.items()
                }
            }
            if study.fidelities
            else {}
        ),
    }


def study_from_record(record: dict[str, Any]) -> Study:
    """The ``Study`` of a record written by :func:`study_record` (trusted: not validated again)."""
    scenes = {scene["name"]: SCENES.load(scene["name"]) for scene in record["scenes"]}
    specs = {**CATALOG, **variable_settings(scenes.values())}
    return Study(
        name=record["study"],
        engine=_engine_of(record["engine"]),
        scenes=scenes,
        settings={scene["name"]: scene["settings"] for scene in record["scenes"]},
        free=[
            FreeParameter(specs[name], p["lower"], p["upper"])
            for p in record["parameters"]
            for name in SPLIT_PARAMETERS.get(p["name"], (p["name"],))
        ],
        fixed=upgrade_parameters(record["fixed"], free_names(record["parameters"])),
        targets=[
            Target(
                t["scene"],
                t["response"],
                t["value"],
                t["weight"],
                t["spread"],
                t.get("lower"),
                t.get("upper"),
                t.get("tests", 1),
                t.get("discrepancy", 0.0),
            )
            for t in record["targets"]
        ],
        replicates=record["replicates"],
        staging=None if record.get("staging") is None else tuple(record["staging"]),
        seed=record["seed"],
        timestep_fraction=record["timestep_fraction"],
        optimizer=OptimizerSettings.from_dict(record["optimizer"]),
        objective_form=record.get("objective", DEFAULT_FORM),
        rayleigh_cost_weight=record["rayleigh_cost_weight"],
        calibration=record["calibration"],
        warnings=record["warnings"],
        archive=record["archive"]["url"] if "archive" in record else _default_archive(),
        reuse=record.get("reuse"),
        material_draws=tuple(record.get("drawn_materials", ())),
        material=record.get("material"),
        fidelities={
            name: FidelityLevel(
                name,
                level["scenes"],
                level["timestep_fraction"],
                _engine_of(level["engine"]),
            )
            for name, level in record.get("fidelities", {}).items()
        },
    )


def _engine_of(record: dict[str, Any]) -> Engine:
    """The engine of a study record's ``{"name": ..., **settings}``."""
    settings = dict(record)
    return make_engine(settings.pop("name"), settings)


def _default_archive() -> str:
    """The archive of a study frozen before studies named one: the default archive."""
    url: str = default("archive")["url"]
    return url


def load_frozen(path: Path | str) -> Study:
    """The study frozen in a ``study.json`` (what jobs and child processes work from)."""
    try:
        return study_from_record(read_json(path, STUDY_FILE))
    except SimulationFailed as exc:
        raise ConfigError(f"{exc}; run the study file again to write it") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(
            f"{path}: not a study written by demcal ({type(exc).__name__}: "
            f"{exc}); remove it and run the study file again"
        ) from None


def incompatible_changes(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """Fields in which ``new`` differs from ``old`` so that stored simulations no longer compare.

    Allowed: the budget and stopping rules (``RESUMABLE_OPTIMIZER_SETTINGS``), a fidelity
    level added,
    the daemon's ``calibration`` settings, warnings, the demcal version, the
    objective's form, the archive, where the material came from (its values are compared as
    fixed parameters and settings), and target values, weights and spreads when the same
    responses are targeted (stored simulations are then re-scored).
    """
    changed = [
        path
        for path in _differences(old, new, "")
        if not path.startswith(
            ("demcal_version", "warnings", "calibration", "objective", "archive", "material")
        )
        # a level added: no stored simulation ran at it
        and not (path.startswith("fidelities") and _at(old, path) is None)
        and not any(
            path == f"optimizer.{name}" or path.startswith(f"optimizer.{name}.")
            for name in RESUMABLE_OPTIMIZER_SETTINGS
        )
    ]
    same_responses = [(t["scene"], t["response"]) for t in old.get("targets", [])] == [
        (t["scene"], t["response"]) for t in new.get("targets", [])
    ]
    if same_responses:
        changed = [
            path
            for path in changed
            if not (
                path.startswith("targets[") and path.rsplit(".", 1)[-1] in RESCORABLE_TARGET_FIELDS
            )
        ]
    return changed


def _differences(old: object, new: object, where: str) -> list[str]:
    """Dotted paths of the leaves in which two JSON values differ."""
    if isinstance(old, dict) and isinstance(new, dict):
        return [
            path
            for key in sorted(set(old) | set(new), key=str)
            for path in _differences(
                old.get(key), new.get(key), f"{where}.{key}" if where else str(key)
            )
        ]
    if (
        isinstance(old, list)
        and isinstance(new, list)
        and len(old) == len(new)
        and any(isinstance(item, (dict, list)) for item in old)
    ):
        return [
            path
            for i, (a, b) in enumerate(zip(old, new))
            for path in _differences(a, b, f"{where}[{i}]")
        ]
    return [] if old == new else [where or "(study)"]


def freeze(study: Study) -> Study:
    """Write the resolved study to ``study.json`` and return it as jobs will read it.

    An existing ``study.json`` (a calibration already started) is compared
    field by field; a change that would mix incomparable simulations is
    refused with every changed field named.
    """
    path = study.files.study
    record = study_record(study)
    if path.exists():
        try:
            old = read_json(path, STUDY_FILE)
        except SimulationFailed as exc:
            raise ConfigError(f"{exc}; move it away to start the study afresh") from None
        if "staging" not in old:  # begun before staging: its evaluations keep running at once
            record["staging"] = None
        if isinstance(old.get("fixed"), dict):  # begun by an earlier demcal: today's names
            old["fixed"] = upgrade_parameters(old["fixed"], free_names(old.get("parameters", [])))
        changed = incompatible_changes(old, record)
        if changed:
            shown = "; ".join(
                f"{name}: {_short(_at(old, name))} -> {_short(_at(record, name))}"
                for name in changed[:5]
            )
            raise ConfigError(
                f"{study.files.dir} holds a calibration of a different study ({shown}); "
                f"give the study a new name, or move {study.files.dir} away"
            )
    write_json_if_changed(path, record)  # unchanged: its time stays, nothing reruns
    return study_from_record(read_json(path, STUDY_FILE))


def _short(value: object, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _at(record: object, dotted: str) -> object:
    """The value at a dotted path such as ``targets[0].response`` (None if absent)."""
    node = record
    for part in dotted.replace("[", ".[").split("."):
        if not part:
            continue
        if part.startswith("["):
            index = int(part[1:-1])
            node = node[index] if isinstance(node, list) and index < len(node) else None
        else:
            node = node.get(part) if isinstance(node, dict) else None
    return node
