"""The surrogate of the objective: its training data and its fit.

Its data are the finished values (with the variance of each, from
replicates) and, given the targets, the objective of every stopped run that
completed all targeted responses, so that a region stopped early is known
to the surrogate and not proposed again. The optimizer refits it only when
this data grew or changed.
"""

from __future__ import annotations

import numpy as np

from demcal.optimizer.objective import ResponseObjective
from demcal.results.records import Status

from .evaluation import Evaluation
from .registry import SURROGATES
from .settings import OptimizerSettings
from .surrogates.base import Surrogate


def training_data(
    records: list[Evaluation], dimension: int, objective: ResponseObjective | None
) -> list[tuple[tuple[float, ...], float, float]] | None:
    """(x, value, variance) of every point the surrogate learns from; None while fewer than
    d + 2 evaluations finished ok."""
    finished = [(r.x, r.value, r.variance or 0.0) for r in records if r.value is not None]
    if len(finished) < dimension + 2:
        return None
    return finished + stopped_values(records, objective)


def stopped_values(
    records: list[Evaluation], objective: ResponseObjective | None
) -> list[tuple[tuple[float, ...], float, float]]:
    """(x, objective, 0) of the stopped runs whose targeted responses were all final."""
    if objective is None:
        return []
    keys = objective.keys
    complete = [
        r
        for r in records
        if r.status == Status.TERMINATED
        and all(key in r.responses and r.responses[key].final for key in keys)
    ]
    return [
        (r.x, float(objective({key: r.responses[key].mean for key in keys})), 0.0) for r in complete
    ]


def fit_surrogate(
    settings: OptimizerSettings, seed: int, data: list[tuple[tuple[float, ...], float, float]]
) -> Surrogate:
    """The surrogate named in ``settings`` fitted on ``data`` (see :func:`training_data`)."""
    model: type[Surrogate] = SURROGATES.load(settings.surrogate_name)
    surrogate = model.create(settings.duplicate_tolerance, settings.kriging_restarts, seed)
    x, y, variance = (np.array(column) for column in zip(*data))
    return surrogate.fit(x, y, variance)
