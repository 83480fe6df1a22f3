"""Objective of one evaluation: weighted sum of squared relative errors.

Samuelsson (2023), eq. 3.3: f = sum_i w_i ((y_i - r_i) / r_i)^2, with y_i the
simulated response averaged over replicates before the error is taken
(section 2.5), and the absolute error where the target r_i is 0.
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
