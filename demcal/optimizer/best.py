"""The best point: which evaluated point a calibration answers with, and how it was chosen.

With response models (an objective and enough responses), the evaluated
point whose objective, applied to the models' predicted responses, is
lowest: noise-aware, since each model averages the scatter of nearby
simulations. Otherwise each evaluated point is scored by the larger of its
observed value and the objective surrogate's prediction there, and the
lowest score wins: a lucky noisy sample (observed low, predicted high) is
passed over, and so is a point where a smoothing surrogate blurs a sharp
valley. A point chosen and then confirmed (:mod:`.confirmation`) stays the
answer.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .bounds import Bounds, on_bounds
from .confirmation import confirmed_id
from .evaluation import BestPoint, Evaluation
from .responses import ResponsePredictor
from .surrogates.base import Surrogate


def best_point(
    records: list[Evaluation],
    bounds: Bounds,
    predictor: Callable[[], ResponsePredictor | None],
    surrogate: Callable[[], Surrogate | None],
) -> BestPoint | None:
    """The best evaluated point (see the module docstring); None before any value.

    ``predictor`` and ``surrogate`` give the fitted models when asked, each
    only if needed.
    """
    finished = [r for r in records if r.finished]
    if not finished:
        return None
    observed = np.array([r.value for r in finished], float)
    points = np.array([r.x for r in finished], float)
    models = predictor()
    if models is not None:
        predicted = models.objective_mean(points)
        index, chosen_by = int(np.argmin(predicted)), "response models"
    else:
        fitted = surrogate()
        predicted = observed if fitted is None else fitted.predict(points)
        index, chosen_by = (
            int(np.argmin(np.maximum(observed, predicted))),
            "objective surrogate",
        )
    confirmed = confirmed_id(records)
    if confirmed is not None:  # the answer stays the point that was chosen and then confirmed
        index = next((i for i, r in enumerate(finished) if r.id == confirmed), index)
    record = finished[index]
    responses = {}
    if models is not None:
        means, stds = models.predict(points[index])
        responses = {key: (float(means[key][0]), float(stds[key][0])) for key in means}
    return BestPoint(
        id=record.id,
        x=bounds.from_unit(record.x)[0].tolist(),
        value=float(observed[index]),
        predicted=float(predicted[index]),
        chosen_by=chosen_by,
        on_bounds=on_bounds(record.x),
        responses=responses,
        reused_from=record.reused_from,
    )


def lowest_run(records: list[Evaluation]) -> Evaluation | None:
    """The evaluated point whose own runs scored lowest (None before any): not the answer,
    which :func:`best_point` chooses from the models of all runs, since one noisy run may be
    lucky."""
    finished = [r for r in records if r.finished and r.value is not None]
    return min(finished, key=lambda r: float(r.value or 0.0), default=None)
