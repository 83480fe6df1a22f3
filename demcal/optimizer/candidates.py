"""Candidate generation and scoring, as small pure functions in the unit box.

MSRS/DYCORS after Samuelsson (2023), section 3.5 and Algorithm 4, who
follows Regis & Shoemaker: candidates are Gaussian perturbations of the
best point with step size sigma; each candidate gets a weighted score of its
surrogate value and its distance to the points already evaluated, running
or given up (the distance set A); the lowest score wins. DYCORS (Regis &
Shoemaker 2013) perturbs each coordinate only with a probability that falls
as the budget is used. The step size doubles after C_success consecutive
improvements and halves after C_fail consecutive non-improvements.

The Kriging strategy scores the same kind of candidates by expected
improvement (Samuelsson 2023, section 2.2.2.3), damped near running points.

The strategy classes that put these together are in :mod:`.strategies`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import minimize
from scipy.spatial.distance import cdist
from scipy.stats import norm

if TYPE_CHECKING:
    from .surrogates.base import Surrogate

IMPROVEMENT_TOLERANCE = 1e-3  # relative improvement that counts as a success


def perturbation_probability(
    dimension: int, evaluated: int, initial_size: int, budget: int
) -> float:
    """DYCORS probability of perturbing a coordinate (Regis & Shoemaker 2013).

    p = min(20/d, 1) * (1 - ln(n - n0 + 1) / ln(N - n0)), floored so that on
    average at least one coordinate moves.
    """
    base = min(20.0 / dimension, 1.0)
    adaptive_budget = budget - initial_size
    if adaptive_budget > 1:
        used = min(max(evaluated - initial_size, 0), adaptive_budget - 1)
        base *= 1.0 - math.log(used + 1) / math.log(adaptive_budget)
    return max(base, 1.0 / dimension)


def perturbation_candidates(
    center: np.ndarray, sigma: float, count: int, probability: float, rng: np.random.Generator
) -> np.ndarray:
    """Candidates y = x* + N(0, sigma^2) on randomly chosen coordinates
    (Samuelsson 2023, sec. 3.5.1.2).

    Each coordinate is perturbed with ``probability`` and at least one per
    candidate; points leaving the unit box are reflected back into it.
    """
    dimension = len(center)
    mask = rng.random((count, dimension)) < probability
    forced = rng.integers(dimension, size=count)
    mask[np.arange(count), forced] = True
    steps = sigma * rng.standard_normal((count, dimension))
    candidates = center + mask * steps
    candidates = np.abs(candidates)  # reflect at 0
    candidates = 1.0 - np.abs(1.0 - candidates)  # reflect at 1
    return np.clip(candidates, 0.0, 1.0)


def nearest_distances(candidates: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Delta_n(x) = min_i ||x - x_i|| over the distance set (Algorithm 4, step b)."""
    if len(points) == 0:
        return np.full(len(candidates), np.inf)
    distances: np.ndarray = cdist(candidates, points).min(axis=1)
    return distances


def rescaled(values: np.ndarray) -> np.ndarray:
    """(v - v_min) / (v_max - v_min), or all ones when the values are equal (steps c–d)."""
    low, high = float(np.min(values)), float(np.max(values))
    if high <= low or not np.isfinite(high - low):
        return np.ones(len(values))
    return (values - low) / (high - low)


def weighted_scores(predicted: np.ndarray, distances: np.ndarray, weight: float) -> np.ndarray:
    """F(x) = w V_R(x) + (1 - w) V_D(x) (Algorithm 4, steps c–e); lower is better.

    V_R rescales the surrogate values, V_D rescales the negated distances so
    that far-away candidates score near 0.
    """
    surrogate_score = rescaled(predicted)
    distance_score = rescaled(-distances)
    return weight * surrogate_score + (1.0 - weight) * distance_score


def surrogate_minimum(surrogate: Surrogate, center: np.ndarray, radius: float) -> np.ndarray:
    """Local minimum of the surrogate in a box of half-width ``radius`` around ``center``.

    An addition to the thesis: at the most exploitative weight of the cycle,
    and for the last share of the budget, this point is proposed directly
    (when admissible), which lets the search refine the optimum below the
    spacing of the random candidates.
    """
    low = np.maximum(center - radius, 0.0)
    high = np.minimum(center + radius, 1.0)
    result = minimize(
        lambda x: float(surrogate.predict(x[None, :])[0]),
        center,
        method="L-BFGS-B",
        bounds=list(zip(low, high)),
        options={"maxiter": 50},
    )
    minimum: np.ndarray = np.clip(result.x, 0.0, 1.0)
    return minimum


def admissible(
    candidates: np.ndarray,
    distance_set: np.ndarray,
    min_distance: float,
    failed: np.ndarray,
    failed_radius: float,
) -> np.ndarray:
    """Mask of candidates not too close to the distance set or to failed points."""
    keep = nearest_distances(candidates, distance_set) > min_distance
    if len(failed):
        keep &= nearest_distances(candidates, failed) > failed_radius
    return keep


def uniform_candidates(count: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """Uniform random points in the unit box."""
    return rng.random((count, dimension))


def most_distant(candidates: np.ndarray, distance_set: np.ndarray) -> np.ndarray:
    """The candidate farthest from the distance set (space filling)."""
    farthest: np.ndarray = candidates[int(np.argmax(nearest_distances(candidates, distance_set)))]
    return farthest


def space_filling_point(
    distance_set: np.ndarray,
    failed: np.ndarray,
    failed_radius: float,
    count: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """The farthest from the distance set of ``count`` uniform candidates, preferring those
    clear of failed points."""
    candidates = uniform_candidates(count, distance_set.shape[1], rng)
    if len(failed):
        keep = nearest_distances(candidates, failed) > failed_radius
        if keep.any():
            candidates = candidates[keep]
    return most_distant(candidates, distance_set)


def expected_improvement(mean: np.ndarray, std: np.ndarray, best: float) -> np.ndarray:
    """EI(x) = E[max(f* - Y(x), 0)] for Y ~ N(mean, std^2) (Samuelsson 2023, sec. 2.2.2.3)."""
    std = np.maximum(std, 1e-12)
    gap = best - mean
    u = gap / std
    improvement: np.ndarray = gap * norm.cdf(u) + std * norm.pdf(u)
    return improvement


def pending_damping(candidates: np.ndarray, pending: np.ndarray, radius: float) -> np.ndarray:
    """Factor in [0, 1] that grows linearly with distance to the nearest running point, up to
    ``radius``.

    Running points are not in the Kriging data; damping EI near them keeps
    parallel workers apart.
    """
    if len(pending) == 0 or radius <= 0:
        return np.ones(len(candidates))
    return np.minimum(nearest_distances(candidates, pending) / radius, 1.0)


@dataclass
class StepSize:
    """Step-size control of MSRS/DYCORS (Samuelsson 2023, sec. 3.5.1.2, Table 4.2).

    ``collapsed`` becomes true when a halving would go below sigma_min.
    """

    sigma: float
    successes: int = 0
    failures: int = 0
    collapsed: bool = False

    def record(
        self,
        improved: bool,
        sigma_min: float,
        sigma_max: float,
        success_tolerance: int,
        failure_tolerance: int,
    ) -> None:
        if improved:
            self.successes += 1
            self.failures = 0
        else:
            self.failures += 1
            self.successes = 0
        if self.successes >= success_tolerance:
            self.sigma = min(2.0 * self.sigma, sigma_max)
            self.successes = 0
        if self.failures >= failure_tolerance:
            if self.sigma / 2.0 < sigma_min * (1 - 1e-12):
                self.collapsed = True
            self.sigma = max(self.sigma / 2.0, sigma_min)
            self.failures = 0


def is_improvement(value: float, best: float | None) -> bool:
    """A value is a success if it beats the best by 0.1 % of |best| (Regis & Shoemaker 2013)."""
    if best is None:
        return True
    return value < best - IMPROVEMENT_TOLERANCE * abs(best)
