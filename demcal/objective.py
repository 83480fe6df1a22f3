"""The objective in every form: final, per replicate, and from early estimates.

Samuelsson (2023), eq. 3.3: f = sum_i w_i ((y_i - r_i) / r_i)^2, with y_i the
simulated response averaged over replicates before the error is taken
(section 2.5), and the absolute error where the target r_i is 0. The
Rayleigh time-step cost (Rackl & Hanley 2017, eq. 10) is added by the
caller as ``cost``. Pure functions: no files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import fmean, stdev


@dataclass(frozen=True)
class Target:
    """A measured response the simulation must match."""

    scene: str
    response: str
    value: float
    weight: float = 1.0
    spread: float | None = None  # measurement standard deviation, same unit as value

    @property
    def key(self) -> str:
        return f"{self.scene}.{self.response}"


def relative_error(simulated: float, target: float) -> float:
    """(y - r) / r, or the absolute error y - r where the target r is 0."""
    if target == 0.0:
        return simulated - target
    return (simulated - target) / target


def replicate_mean(values: list[float]) -> float:
    """Mean of the replicates of one response (Samuelsson 2023, sec. 2.5)."""
    return fmean(values)


def replicate_spread(values: list[float]) -> float:
    """Sample standard deviation of the replicates (0 for a single replicate)."""
    return stdev(values) if len(values) > 1 else 0.0


def objective_value(targets: list[Target], mean_responses: dict[str, float]) -> float:
    """Weighted sum of squared relative errors (Samuelsson 2023, eq. 3.3).

    ``mean_responses`` maps ``scene.response`` to the replicate mean.
    """
    total = 0.0
    for t in targets:
        error = relative_error(mean_responses[t.key], t.value)
        total += t.weight * error * error
    if not math.isfinite(total):
        raise ValueError(f"objective is not finite ({total}); responses {mean_responses}")
    return total


def replicate_objectives(targets: list[Target], replicates: dict[str, list[float]],
                         cost: float = 0.0) -> list[float]:
    """Eq. 3.3 of each replicate index alone (for the optimizer's noise estimate).

    Empty unless every targeted response has the same number (> 1) of replicates.
    """
    counts = {len(replicates.get(t.key, [])) for t in targets}
    if len(counts) != 1 or counts in ({0}, {1}):
        return []
    return [objective_value(targets, {t.key: replicates[t.key][i] for t in targets}) + cost
            for i in range(counts.pop())]


def estimated_objective(targets: list[Target], estimates: dict[str, list[float]],
                        cost: float = 0.0) -> float | None:
    """Objective from early estimates of a running evaluation (thesis sec. 3.6.1).

    Each targeted response's estimates are averaged over the replicates that
    have one; the sum runs over the targets with an estimate, so it is a
    lower bound of eq. 3.3 while some responses have none yet. None when no
    target has an estimate or the sum is not finite.
    """
    total, used = cost, 0
    for t in targets:
        values = estimates.get(t.key)
        if values:
            error = relative_error(sum(values) / len(values), t.value)
            total += t.weight * error * error
            used += 1
    return total if used and math.isfinite(total) else None
