"""Which lab test to measure next: the expected shrink of the solution set (``demcal advise``).

Two lab measurements seldom pin a DEM material (Rackl & Hanley 2017, sec. 4; Richter & Will
2021, sec. 6): more tests are the way out. For each candidate test demcal can simulate, the
advice

1. takes K parameter sets that span the study's likely solution set (`spanning_sets`:
   greedy maximin, preferring the sets the study has simulated, whose runs a joint study
   reuses);
2. simulates the candidate test at each of them (elsewhere: ``demcal.cli.advise``);
3. fits each candidate response over the set by least squares (`fit_plane`: a plane needs
   K >= d + 1 sets; its residual gives the model's uncertainty);
4. takes each of the K sets in turn as the truth: the response simulated there becomes a
   target with the response's measurement spread, the solution set is judged anew on the
   study's models and the plane (`spans_after`), and each free parameter's likely span is
   read off it. The mean over the K truths is the expected span (`Shrink`).

Pure functions of the study's `SolutionSet` and the candidate's values; the files, figure
and words are in ``demcal.analysis.advice_report``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from demcal.analysis.solutions import SolutionSet
from demcal.optimizer.membership import LIKELY, membership_probability
from demcal.optimizer.objective import Target

#: A set the study simulated is taken instead of a new one at least this share as far from the
#: sets already taken (`spanning_sets`).
REUSE_SPACING = 0.75


@dataclass(frozen=True)
class PlaneFit:
    """A response over the unit box as a least-squares plane, y = c0 + c . x.

    ``inverse_gram``: (X^T X)^-1 of the design with its column of ones; ``residual_sd``:
    the residuals' sd over their K - d - 1 degrees of freedom, 0 when the plane passes
    through d + 1 sets exactly (nothing to judge it by).
    """

    coefficients: np.ndarray
    inverse_gram: np.ndarray
    residual_sd: float

    def predict(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(_design(x) @ self.coefficients)

    def predict_std(self, x: np.ndarray) -> np.ndarray:
        """The sd of the plane's estimate of the mean response at ``x`` (the classical
        least-squares confidence band, s sqrt(x^T (X^T X)^-1 x))."""
        design = _design(x)
        leverage = np.einsum("ij,jk,ik->i", design, self.inverse_gram, design)
        return np.asarray(self.residual_sd * np.sqrt(np.maximum(leverage, 0.0)))


def _design(x: np.ndarray) -> np.ndarray:
    x = np.atleast_2d(np.asarray(x, float))
    return np.column_stack([np.ones(len(x)), x])


def fit_plane(x: np.ndarray, y: np.ndarray) -> PlaneFit:
    """The least-squares plane through K >= d + 1 points ``x`` (unit box) with values ``y``."""
    design = _design(x)
    freedom = len(design) - design.shape[1]
    if freedom < 0:
        raise ValueError(
            f"a plane in {design.shape[1] - 1} parameters needs {design.shape[1]} sets"
        )
    coefficients, *_ = np.linalg.lstsq(design, np.asarray(y, float), rcond=None)
    residual = np.asarray(y, float) - design @ coefficients
    residual_sd = math.sqrt(float(residual @ residual) / freedom) if freedom else 0.0
    return PlaneFit(coefficients, np.linalg.pinv(design.T @ design), residual_sd)


def spanning_sets(likely: np.ndarray, simulated: np.ndarray, count: int) -> list[tuple[bool, int]]:
    """``count`` sets that span the ``likely`` points (unit box), greedy maximin: first the
    point farthest from their centroid, then each time the one farthest from those taken. A
    set the study has ``simulated`` is taken instead of the best new point whenever it lies
    at least ``REUSE_SPACING`` as far from those taken: its runs are reused, at a small loss
    of the design's spacing. Each set as (simulated?, its row in
    ``simulated`` or ``likely``)."""
    likely = np.asarray(likely, float)
    simulated = np.asarray(simulated, float).reshape(-1, likely.shape[1])
    centroid = likely.mean(axis=0)
    far_new = np.linalg.norm(likely - centroid, axis=1)
    far_old = np.linalg.norm(simulated - centroid, axis=1)
    chosen: list[tuple[bool, int]] = []
    while len(chosen) < count:
        best = int(np.argmax(far_new))
        near = int(np.argmax(far_old)) if len(far_old) else -1
        if near >= 0 and far_old[near] >= REUSE_SPACING * far_new[best] and far_old[near] > 0:
            chosen.append((True, near))
            point = simulated[near]
        else:
            chosen.append((False, best))
            point = likely[best]
        far_new = np.minimum(far_new, np.linalg.norm(likely - point, axis=1))
        far_old = np.minimum(far_old, np.linalg.norm(simulated - point, axis=1))
    return chosen


def spans_after(
    solutions: SolutionSet, key: str, fit: PlaneFit, truths: np.ndarray, spread: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each free parameter's likely span (unit box) once the response ``key`` is a target at
    each of the values ``truths`` with the measurement ``spread``: per truth, the sets of the
    study's solution set still at least as likely in as out when the study's membership is
    multiplied by the new target's (`membership_probability` on the plane ``fit``). Rows of
    NaN where no set would remain likely."""
    points = solutions.points_unit
    means = {key: fit.predict(points)}
    stds = {key: fit.predict_std(points)}
    scene, response = key.split(".", 1)
    lows = np.full((len(truths), points.shape[1]), math.nan)
    highs = np.full_like(lows, math.nan)
    for j, value in enumerate(truths):
        target = Target(scene, response, value=float(value), spread=spread)
        joint = solutions.probability * membership_probability(
            (target,), means, stds, {key: 0.0}, solutions.k
        )
        likely = points[joint >= LIKELY]
        if len(likely):
            lows[j], highs[j] = likely.min(axis=0), likely.max(axis=0)
    return lows, highs


@dataclass(frozen=True)
class Shrink:
    """What measuring one candidate response would do to the likely set.

    ``before``: each free parameter's likely span now (share of its box); ``lows`` and
    ``highs``: its span (unit box) with each of the K truths' targets added (rows; NaN where
    none would remain); ``spread``: the measurement spread assumed; ``cpu_s``: the CPU
    seconds of one simulation of the test; ``residual_sd``: the plane's misfit.
    """

    scene: str
    response: str
    unit: str
    spread: float
    before: np.ndarray
    lows: np.ndarray
    highs: np.ndarray
    cpu_s: float
    residual_sd: float

    @property
    def key(self) -> str:
        return f"{self.scene}.{self.response}"

    @property
    def after(self) -> np.ndarray:
        """Each free parameter's expected likely span (share of its box), over the truths."""
        widths = self.highs - self.lows
        if np.all(np.isnan(widths)):
            return np.full(widths.shape[1], math.nan)
        return np.asarray(np.nanmean(widths, axis=0))

    def score(self, chosen: np.ndarray) -> float:
        """The mean expected span of the ``chosen`` parameters (a boolean mask), share of
        their boxes: the smaller, the more the test pins them."""
        after = self.after[chosen]
        return float(np.mean(after)) if np.all(np.isfinite(after)) else math.inf


def rank(shrinks: list[Shrink], chosen: np.ndarray) -> list[Shrink]:
    """The candidates, the one that narrows the ``chosen`` parameters most first; ties go to
    the cheaper test."""
    return sorted(shrinks, key=lambda s: (s.score(chosen), 0.0 if math.isnan(s.cpu_s) else s.cpu_s))
