"""A material calibrated on a sampled domain's global metamodels, with no simulation (Richter
& Will 2021, sec. 4): L-BFGS-B from many starts on the objective of the material's targets over
the models' predictions, the distinct optima, and the solution set of the material's free box
on those models."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from demcal.domain.metamodel import Metamodels, Model
from demcal.errors import ConfigError
from demcal.optimizer.membership import band_half_width
from demcal.optimizer.objective import ResponseObjective
from demcal.study.model import Study

if TYPE_CHECKING:
    from demcal.analysis.solution_report import SolutionAnalysis


@dataclass(frozen=True)
class Optimum:
    """A local optimum of the objective on the metamodels: free values, objective, the
    predicted responses and the models' sd of them, and how many starts ended there."""

    values: dict[str, float]
    objective: float
    predicted: dict[str, float]
    predicted_sd: dict[str, float]
    starts: int


@dataclass(frozen=True)
class MetamodelCalibration:
    """A material calibrated on a domain's metamodels (Richter & Will 2021, sec. 4): every
    distinct optimum, best first, the inputs held at the material's values, and the solution
    set of the material's free box on those models with a verdict per free parameter
    (:mod:`demcal.analysis.solutions`)."""

    optima: list[Optimum]
    held: dict[str, float]
    analysis: SolutionAnalysis


@dataclass(frozen=True)
class MaterialResponse:
    """One global model seen from a material's free box: points in the unit box of the
    material's free parameters, mapped to the domain's inputs by ``inputs`` (held ones at the
    material's values). Mean, sd and noise, as the solution-space analysis reads a model."""

    models: Metamodels
    key: str
    kind: str
    inputs: Callable[[np.ndarray], np.ndarray]

    @property
    def model(self) -> Model:
        return self.models.models[self.key][self.kind]

    def predict(self, x: np.ndarray) -> np.ndarray:
        return self.model.predict(self.models.unit(self.inputs(x)))

    def predict_std(self, x: np.ndarray) -> np.ndarray:
        return self.model.predict_std(self.models.unit(self.inputs(x)))

    @property
    def noise_sd(self) -> float:
        return self.model.noise_sd


def material_inputs(domain: Study, material: Study) -> tuple[list[str], dict[str, float]]:
    """The domain's inputs the material frees, and the value it holds each other one at (a
    fixed parameter or a scene setting such as the d50 of ``demcal psd fit``).

    Refused, naming the field: a material of another scene or engine, a free parameter that
    is not an input of the models, a held value or bound outside the domain, and a setting,
    fixed parameter or time-step fraction of the domain the material gives another value (the
    models know only one)."""
    if set(material.scenes) != set(domain.scenes) or material.engine.name != domain.engine.name:
        raise ConfigError(
            f"the material's scenes {', '.join(material.scenes)} on {material.engine.name} are "
            f"not the domain's ({', '.join(domain.scenes)} on {domain.engine.name})"
        )
    bounds = {p.name: (p.lower, p.upper) for p in domain.free}
    free = []
    for p in material.free:
        if p.name not in bounds:
            raise ConfigError(
                f"parameters.{p.name}: not an input of the domain's models "
                f"({', '.join(bounds)}); fix it at the domain's value"
            )
        lower, upper = bounds[p.name]
        if p.lower < lower or p.upper > upper:
            raise ConfigError(
                f"parameters.{p.name}: [{p.lower:g}, {p.upper:g}] leaves the domain "
                f"[{lower:g}, {upper:g}]; the models would extrapolate"
            )
        free.append(p.name)
    scene = next(iter(domain.scenes))
    domain_settings, domain_fixed, _ = domain.archive_view(scene)
    settings, fixed, _ = material.archive_view(scene)
    for name, value in domain_settings.items():
        if settings.get(name) != value:
            raise ConfigError(
                f"scenes.{scene}.settings.{name}: the domain's models were trained at {value}, "
                f"the material gives {settings.get(name)}; they do not know another value"
            )
    if material.timestep_fraction != domain.timestep_fraction:
        raise ConfigError(
            f"timestep_fraction: the domain's models were trained at {domain.timestep_fraction:g}, "
            f"the material gives {material.timestep_fraction:g}"
        )
    held = {}
    for name, (lower, upper) in bounds.items():
        if name in free:
            continue
        value = fixed.get(name)
        where = f"scenes.{scene}.settings" if name in material.settings[scene] else "fixed"
        if value is None or not lower <= value <= upper:
            raise ConfigError(
                f"{where}.{name}: {value} is outside the domain [{lower:g}, {upper:g}] of the "
                f"models; give a value inside it or make it free"
            )
        held[name] = float(value)
    for name, value in domain_fixed.items():
        if name not in bounds and fixed.get(name) != value:
            where = f"scenes.{scene}.settings" if name in material.settings[scene] else "fixed"
            raise ConfigError(
                f"{where}.{name}: the domain's models were trained at {value:g}, the material "
                f"gives {fixed.get(name)}; they do not know another value"
            )
    return free, held


def calibrate(
    models: Metamodels,
    kind: str,
    material: Study,
    free: list[str],
    held: dict[str, float],
    starts: int,
    explore_command: str,
    seed: int = 1,
    samples: int = 2**16,
) -> MetamodelCalibration:
    """L-BFGS-B on the material's objective of the predicted responses, from ``starts``
    Sobol points of its free box (optima closer than 0.02 of the box are one); then the
    solution set of the box on the same models (``samples`` points; ``explore_command``:
    how to add simulations where the models cannot decide)."""
    from scipy.optimize import minimize

    from demcal.analysis.solution_report import analyse_predictor
    from demcal.optimizer.designs import sobol_sequence
    from demcal.optimizer.responses import ResponsePredictor

    objective = with_discrepancy(
        material.objective, {key: models.models[key][kind].discrepancy_sd for key in models.models}
    )
    specs = {p.name: p for p in material.free}
    low = np.array([specs[n].lower for n in free])
    high = np.array([specs[n].upper for n in free])

    def inputs(unit: np.ndarray) -> np.ndarray:
        unit = np.atleast_2d(unit)
        values = {n: low[i] + unit[:, i] * (high[i] - low[i]) for i, n in enumerate(free)}
        values |= {n: np.full(len(unit), v) for n, v in held.items()}
        return np.column_stack([values[n] for n in models.names])

    view = {key: MaterialResponse(models, key, kind, inputs) for key in objective.keys}
    predictor = ResponsePredictor(view, objective)

    def predicted(unit: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
        means, stds = predictor.predict(unit)
        return {k: float(v[0]) for k, v in means.items()}, {k: float(v[0]) for k, v in stds.items()}

    rng = np.random.default_rng(seed)
    ends = []
    for start in sobol_sequence(starts, len(free), rng):
        result = minimize(
            lambda unit: float(predictor.objective_mean(unit)[0]),
            start,
            method="L-BFGS-B",
            bounds=[(0.0, 1.0)] * len(free),
        )
        ends.append((float(result.fun), np.clip(result.x, 0.0, 1.0)))
    ends.sort(key=lambda end: end[0])
    optima: list[tuple[np.ndarray, float, int]] = []
    for fun, unit in ends:
        for i, (kept, kept_fun, count) in enumerate(optima):
            if np.linalg.norm(unit - kept) < 0.02 * math.sqrt(len(free)):
                optima[i] = (kept, kept_fun, count + 1)
                break
        else:
            optima.append((unit, fun, 1))
    analysis = analyse_predictor(
        predictor,
        {key: model.noise_sd for key, model in view.items()},
        free,
        [specs[n].spec.unit for n in free],
        low,
        high,
        explore_command,
        samples=samples,
        seed=seed,
    )
    return MetamodelCalibration(
        [
            Optimum(
                {n: float(low[i] + unit[i] * (high[i] - low[i])) for i, n in enumerate(free)},
                fun,
                *predicted(unit),
                count,
            )
            for unit, fun, count in optima
        ],
        held,
        analysis,
    )


def with_discrepancy(objective: ResponseObjective, model_sd: dict[str, float]) -> ResponseObjective:
    """``objective`` with each target's discrepancy widened by its model's own error about the
    simulator (``model_sd``, combined in quadrature): the band a metamodel without a posterior
    must judge a set by."""
    targets = tuple(
        replace(t, discrepancy=math.hypot(t.discrepancy, model_sd.get(t.key, 0.0)))
        for t in objective.targets
    )
    return replace(objective, targets=targets)


def no_solution_reason(result: MetamodelCalibration) -> str:
    """Why no parameter set is likely to meet every target: the models do not reach the
    targets, or they do but are too unsure there to say where."""
    best, solutions = result.optima[0], result.analysis.solutions
    targets = result.analysis.predictor.objective.targets
    band = {t.key: band_half_width(t, solutions.noise_sd[t.key], solutions.k) for t in targets}
    if all(
        (accepted := t.accepted(band[t.key]))[0] <= best.predicted[t.key] <= accepted[1]
        for t in targets
    ):
        widths = ", ".join(
            f"{key} sd {best.predicted_sd[key]:.3g} against ±{band[key]:.3g}" for key in band
        )
        return (
            "the models reach every target at optimum 1, but are too unsure there to tell "
            f"which parameter sets meet them ({widths}): more simulations of the domain, or "
            "targets with the spread of their measurement, narrow it"
        )
    return (
        "no parameter set of the free box is likely to meet every target: they lie outside "
        "what the domain gives for this material's held values; the optimum is the nearest "
        "the models reach"
    )
