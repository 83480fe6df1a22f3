"""Responses, not one number: per-response observations and one model per response.

Each evaluation the optimizer is told about may carry its responses: every
replicate's value per ``scene.response``, and for a run stopped early the
responses it did complete (``final``, e.g. a fill's bulk density) or early
estimates of them (not final). :func:`observations` turns the records into
training data per response (the replicate mean, the variance of that mean,
an estimate's own uncertainty); :class:`ResponseModels` fits one model per
response on it (Rackl & Hanley 2017, sec. 2.3: a Kriging metamodel per
response; Richter & Will 2021, sec. 3.7: metamodels per response) and
refits only when a response's data changed. :class:`ResponsePredictor`
applies the objective on top of the predictions, so the structure
"objective = f(responses)" is used, not learnt.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from demcal.optimizer.objective import ResponseObjective, Target
from demcal.results.records import Status

from .evaluation import Evaluation
from .levels import pays
from .registry import RESPONSE_MODELS
from .surrogates.base import ResponseModel
from .surrogates.kriging import KrigingSurrogate
from .surrogates.material import MaterialKriging, offsets_matrix
from .surrogates.multi_fidelity import LevelData, MultiFidelityKriging

#: Standard deviation of an early estimate relative to its value, when a run
#: stopped before the response was final (the calibration device's mass flow
#: over 20-50 % of the discharge against the final 20-80 %).
ESTIMATE_RELATIVE_SD = 0.05


def observations(
    records: list[Evaluation], key: str, dimension: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Training data of one response: points (unit box), means and the variance of each mean.

    A final value's variance is that of its replicates' mean (0 with one
    replicate: the model's nugget then carries the noise); an early estimate
    gets ``ESTIMATE_RELATIVE_SD`` of its value as standard deviation.
    """
    rows = _observed(records, key)
    return (
        np.array([r.x for r, _, _ in rows], float).reshape(len(rows), dimension),
        np.array([mean for _, mean, _ in rows], float),
        np.array([var for _, _, var in rows], float),
    )


def _observed(records: list[Evaluation], key: str) -> list[tuple[Evaluation, float, float]]:
    """The records with a finite value of response ``key``, each with its mean and the
    variance of that mean (:func:`observations`)."""
    rows = []
    for record in records:
        entry = record.responses.get(key)
        if record.status not in (Status.OK, Status.TERMINATED) or not entry or not entry.values:
            continue
        values = np.asarray(entry.values, float)
        mean = float(values.mean())
        if not math.isfinite(mean):
            continue
        if entry.final:
            var = float(values.var(ddof=1) / len(values)) if len(values) > 1 else 0.0
        else:
            var = (ESTIMATE_RELATIVE_SD * mean) ** 2
        rows.append((record, mean, var))
    return rows


def material_offsets(records: list[Evaluation], key: str, names: list[str]) -> np.ndarray:
    """Per record :func:`observations` keeps for response ``key``, its material offset in each
    of ``names`` (:attr:`Evaluation.material`; 0 for the study's own runs)."""
    return offsets_matrix([record.material for record, _, _ in _observed(records, key)], names)


def final_means(
    records: list[Evaluation], key: str, dimension: int
) -> tuple[np.ndarray, np.ndarray]:
    """Points (unit box) and replicate means of one response where it was simulated to the end."""
    rows = [
        (record.x, entry.mean)
        for record in records
        if record.status in (Status.OK, Status.TERMINATED)
        and (entry := record.responses.get(key))
        and entry.values
        and entry.final
    ]
    rows = [(x, y) for x, y in rows if math.isfinite(y)]
    return (
        np.array([x for x, _ in rows], float).reshape(len(rows), dimension),
        np.array([y for _, y in rows], float),
    )


def replicate_scatter(records: list[Evaluation], key: str) -> float:
    """The variance of single simulations of one response, pooled over every point simulated
    more than once (replicates, confirmation runs); 0 where none was.

    The deviations of each point's final values from their mean, over
    their degrees of freedom: the noise that no model of the response can
    be surer than.
    """
    values: dict[tuple[float, ...], list[float]] = {}
    for record in records:
        entry = record.responses.get(key)
        if record.status in (Status.OK, Status.TERMINATED) and entry and entry.final:
            values.setdefault(record.x, []).extend(entry.values)
    groups = [np.asarray(v, float) for v in values.values() if len(v) > 1]
    groups = [g for g in groups if np.all(np.isfinite(g))]
    freedom = sum(len(g) - 1 for g in groups)
    if not freedom:
        return 0.0
    return float(sum(np.sum((g - g.mean()) ** 2) for g in groups) / freedom)


def replicates_per_evaluation(records: list[Evaluation], key: str) -> int:
    """The most common number of final values of one response per evaluation (1 without any)."""
    counts = [len(r.responses[key].values) for r in records if key in r.responses]
    return int(np.median(counts)) if counts else 1


#: A Kriging response model is refitted from the last fit's length scales and
#: nugget with one start; every this many refits, whenever the data grew by a
#: quarter, and after a degenerate fit, with all ``kriging_restarts`` starts.
FULL_REFIT_EVERY = 8


@dataclass(frozen=True)
class LevelVerdict:
    """Whether a cheaper level pays for one response (:func:`.levels.pays`): the correlation
    of its model's predictions with the fine values at the fine points, how many, the cost
    ratio it was judged at."""

    correlation: float
    points: int
    cost_ratio: float
    pays: bool


class ResponseModels:
    """One model per response, refitted only when that response's data changed; with a cheaper
    level's data, a multi-fidelity model where the level pays for the response."""

    def __init__(self, kind: str, duplicate_tolerance: float, restarts: int, seed: int):
        self.kind, self.duplicate_tolerance = kind, duplicate_tolerance
        self.restarts, self.seed = restarts, seed
        self._fitted: dict[str, tuple[tuple[object, ...], PredictsResponse]] = {}
        #: per response: refits since the last full one, and the data size then
        self._since_full: dict[str, tuple[int, int]] = {}
        #: per response: whether the cheaper level pays, as last judged
        self.verdicts: dict[str, LevelVerdict] = {}
        self._verdict_data: dict[str, tuple[object, ...]] = {}

    def fit(
        self,
        records: list[Evaluation],
        keys: list[str],
        dimension: int,
        cheap: list[Evaluation] | None = None,
        cost_ratio: float = math.nan,
        neighbours: list[Evaluation] | None = None,
    ) -> dict[str, PredictsResponse] | None:
        """The models of ``keys``, or None while some response has fewer than d + 2 points.
        ``cheap``: evaluations at a cheaper level, costing ``cost_ratio`` of a fine one;
        ``neighbours``: the archive's points of neighbouring materials (their offsets become
        inputs, :class:`~.surrogates.material.MaterialKriging`)."""
        models = {}
        for key in keys:
            x, y, variance = observations(records, key, dimension)
            near = observations(neighbours or [], key, dimension)
            if len(y) + len(near[1]) < dimension + 2:
                return None
            floor = replicate_scatter(records, key) / replicates_per_evaluation(records, key)
            levels = observations(cheap or [], key, dimension)
            if not self._level_pays(key, (x, y), levels, cost_ratio):
                levels = (np.empty((0, dimension)), np.empty(0), np.empty(0))
            signature = (
                *(a.tobytes() for a in (x, y, variance, levels[1], near[1])),
                floor,
            )
            cached = self._fitted.get(key)
            if cached is None or cached[0] != signature:
                model: PredictsResponse = (
                    self._material_model((x, y, variance), near, neighbours or [], key, floor)
                    if len(near[1])
                    else self._model(key, (x, y, variance), levels, floor)
                )
                self._fitted[key] = (signature, model)
            models[key] = self._fitted[key][1]
        return models

    def _material_model(
        self,
        own: tuple[np.ndarray, np.ndarray, np.ndarray],
        near: tuple[np.ndarray, np.ndarray, np.ndarray],
        neighbours: list[Evaluation],
        key: str,
        floor: float,
    ) -> MaterialKriging:
        """A new model of response ``key`` from the study's own data and its neighbouring
        materials' (``near``, from the records ``neighbours``), their offsets as inputs."""
        names = sorted({name for r in neighbours for name in r.material})
        offsets = material_offsets(neighbours, key, names)
        x, y, variance = (np.concatenate([mine, theirs]) for mine, theirs in zip(own, near))
        return MaterialKriging(self.duplicate_tolerance, self.restarts, self.seed).fit(
            x, y, variance, np.vstack([np.zeros((len(own[1]), len(names))), offsets]), floor
        )

    def _model(
        self,
        key: str,
        fine: tuple[np.ndarray, np.ndarray, np.ndarray],
        cheap: tuple[np.ndarray, np.ndarray, np.ndarray],
        floor: float,
    ) -> PredictsResponse:
        """A new model of one response: multi-fidelity with a cheaper level's data, else the
        configured kind, warm-started from the last fit between full refits."""
        x, y, variance = fine
        if len(cheap[1]):
            return MultiFidelityKriging(self.restarts, self.seed).fit(
                [LevelData(*cheap), LevelData(x, y, variance)], floor
            )
        cached = self._fitted.get(key)
        last = cached[1] if cached is not None and isinstance(cached[1], ResponseModel) else None
        refits, size = self._since_full.get(key, (0, 0))
        due = last is None or refits + 1 >= FULL_REFIT_EVERY or len(y) > 1.25 * size
        start = None if due or last is None else last.warm_start
        kind: type[ResponseModel] = RESPONSE_MODELS.load(self.kind)
        model = kind.create(self.duplicate_tolerance, self.restarts, self.seed, warm_start=start)
        self._since_full[key] = (0, len(y)) if start is None else (refits + 1, size)
        return model.fit(x, y, variance, noise_floor=floor)

    def _level_pays(
        self,
        key: str,
        fine: tuple[np.ndarray, np.ndarray],
        cheap: tuple[np.ndarray, np.ndarray, np.ndarray],
        cost_ratio: float,
    ) -> bool:
        """Whether the cheaper level pays for response ``key`` (:func:`.levels.pays`): a model
        of its data alone, predicted at the fine points, correlated with the fine values."""
        x, y = fine
        dimension = x.shape[1]
        if len(cheap[1]) < dimension + 2 or not math.isfinite(cost_ratio):
            self.verdicts.pop(key, None)
            return False
        data = (x.tobytes(), y.tobytes(), cheap[1].tobytes(), cost_ratio)
        if self._verdict_data.get(key) != data:
            model = KrigingSurrogate(self.duplicate_tolerance, self.restarts, self.seed)
            predicted = model.fit(cheap[0], cheap[1], cheap[2]).predict(x)
            r = float(np.corrcoef(predicted, y)[0, 1]) if np.ptp(predicted) > 0 else 0.0
            self.verdicts[key] = LevelVerdict(r, len(y), cost_ratio, pays(r, len(y), cost_ratio))
            self._verdict_data[key] = data
        return self.verdicts[key].pays


class PredictsResponse(Protocol):
    """What a predictor needs of a response's model: mean and sd at points of the unit box,
    and the scatter of single simulations (an optimizer's :class:`ResponseModel`, or a global
    metamodel seen from a material's box, :class:`demcal.domain.calibration.MaterialResponse`)."""

    def predict(self, x: np.ndarray) -> np.ndarray: ...

    def predict_std(self, x: np.ndarray) -> np.ndarray: ...

    @property
    def noise_sd(self) -> float: ...


@dataclass(frozen=True)
class ResponsePredictor:
    """Response models with the objective on top: what the response strategies and best() use."""

    models: Mapping[str, PredictsResponse]
    objective: ResponseObjective

    def predict(self, x: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Predicted mean and standard deviation of each response at the rows of ``x``."""
        x = np.atleast_2d(x)
        means = {key: model.predict(x) for key, model in self.models.items()}
        stds = {key: model.predict_std(x) for key, model in self.models.items()}
        return means, stds

    def allowed_miss(self, target: Target) -> float:
        """How far a response may miss its target and still meet it: the target's spread or,
        without a spread or where larger, the simulation noise the model's fit found."""
        return max(target.spread or 0.0, self.models[target.key].noise_sd)

    def noise_level(self) -> float:
        """The objective of responses that each miss their target by :meth:`allowed_miss`:
        what noise alone makes of the objective, the scale an improvement is judged on."""
        missed = {t.key: t.missed_by(self.allowed_miss(t)) for t in self.objective.targets}
        return float(np.asarray(self.objective(missed)))

    def meets_targets(self, x: np.ndarray) -> bool:
        """Whether the predicted responses at the point ``x`` (unit box) each lie within
        :meth:`allowed_miss` of their target."""
        means, _ = self.predict(np.atleast_2d(x)[:1])
        return all(
            (band := t.accepted(self.allowed_miss(t)))[0] <= float(means[t.key][0]) <= band[1]
            for t in self.objective.targets
        )

    def objective_mean(self, x: np.ndarray) -> np.ndarray:
        """The objective of the predicted responses (the plug-in estimate) at the rows of ``x``."""
        means, _ = self.predict(x)
        return np.asarray(self.objective(means), float) * np.ones(len(np.atleast_2d(x)))

    def expected_improvement(
        self, x: np.ndarray, best: float, rng: np.random.Generator, samples: int = 128
    ) -> np.ndarray:
        """Monte Carlo expected improvement of the objective over ``best`` at the rows of ``x``.

        Each response is drawn from its model's normal posterior (independent
        responses, the same draws for every candidate), the objective is
        applied to each draw, and the improvements are averaged.
        """
        means, stds = self.predict(x)
        draws = rng.standard_normal((samples, len(self.models)))
        sampled = {
            key: means[key][None, :] + stds[key][None, :] * draws[:, [i]]
            for i, key in enumerate(self.models)
        }
        improvement: np.ndarray = np.maximum(
            best - np.asarray(self.objective(sampled), float), 0.0
        ).mean(axis=0)
        return improvement
