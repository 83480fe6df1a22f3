"""The objective in every form: final, per replicate, from early estimates, on predictions.

Two forms, chosen per study (``objective:``):

* ``relative`` — Samuelsson (2023), eq. 3.3: f = sum_i w_i ((y_i - r_i) / r_i)^2,
  with y_i the simulated response averaged over replicates before the error
  is taken (section 2.5), and the absolute error where the target r_i is 0;
* ``precision`` — each error in units of the target's measurement spread,
  f = sum_i w_i ((y_i - r_i) / s_i)^2, so that a response measured to 0.3 %
  weighs as much per standard deviation as one measured to 7 % (the
  thesis' future-work remark on weighting responses by their uncertainty).
  The simulation noise enters where responses are modelled: the optimizer's
  response models give each prediction a standard deviation.

The Rayleigh time-step cost (Rackl & Hanley 2017, eq. 10) is added by the
caller as ``cost``. Pure functions: no files.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from statistics import fmean, stdev
from typing import Any, TypeVar

import numpy as np

#: The forms of the objective: squared relative errors (Samuelsson 2023, eq. 3.3), or squared
#: errors in units of the targets' spreads (``precision``). The study file also takes ``auto``
#: (precision where every target has a spread; the schema's enum).
RELATIVE, PRECISION = "relative", "precision"
OBJECTIVE_FORMS = (RELATIVE, PRECISION)
#: The form a study gets when it names none and its targets have no spreads
#: (``Study.objective_form``).
DEFAULT_FORM = RELATIVE

#: A response as a number, or as an array of them (model predictions, posterior samples).
Values = TypeVar("Values", float, np.ndarray)


@dataclass(frozen=True)
class Target:
    """A response the simulation must match (``value``), or keep within bounds.

    With ``lower`` and/or ``upper`` (a design's constraint or one-sided goal: a throughput
    of at least, a spillage of at most), any response inside [lower, upper] meets the
    target and the error is the distance to the bound it passes; ``value`` is then the
    bound (the lower one when both are given), the reference a relative error is taken to.
    """

    scene: str
    response: str
    value: float
    weight: float = 1.0
    spread: float | None = None  # sd of single lab tests, same unit as value
    lower: float | None = None
    upper: float | None = None
    tests: int = 1  # lab tests the value is the mean of
    discrepancy: float = 0.0  # sd of the simulated test's difference from the real one

    @property
    def key(self) -> str:
        return f"{self.scene}.{self.response}"

    @property
    def standard_error(self) -> float:
        """The standard error of the measured value: spread / sqrt(tests)."""
        return (self.spread or 0.0) / math.sqrt(self.tests)

    @property
    def is_band(self) -> bool:
        return self.lower is not None or self.upper is not None

    def nearest(self, simulated: float | np.ndarray) -> np.ndarray:
        """The acceptable response nearest to ``simulated``: the value, or ``simulated``
        clipped into the bounds."""
        y = np.asarray(simulated, float)
        if not self.is_band:
            return np.full(y.shape, self.value)
        low, high = self.accepted()
        clipped: np.ndarray = np.clip(y, low, high)
        return clipped

    def accepted(
        self, margin: float | np.ndarray = 0.0
    ) -> tuple[float | np.ndarray, float | np.ndarray]:
        """The responses that meet the target within ``margin``: (low, high), ±inf if open."""
        if not self.is_band:
            return self.value - margin, self.value + margin
        low = -np.inf if self.lower is None else self.lower - margin
        high = np.inf if self.upper is None else self.upper + margin
        return low, high

    def missed_by(self, miss: Values) -> Values:
        """A response that misses the target by ``miss`` (>= 0): past its upper bound where it
        has one, else below its lower bound, else above its value."""
        if self.upper is not None:
            return self.upper + miss
        if self.lower is not None:
            return self.lower - miss
        return self.value + miss

    def shown(self) -> str:
        """The target as a person reads it: 25 ± 0.6, ≥ 50, ≤ 0.01 or 0.45 … 0.55."""
        if self.lower is not None and self.upper is not None:
            return f"{self.lower:.4g} … {self.upper:.4g}"
        if self.lower is not None:
            return f"≥ {self.lower:.4g}"
        if self.upper is not None:
            return f"≤ {self.upper:.4g}"
        shown = f"{self.value:.4g}" + (f" ± {self.spread:.2g}" if self.spread else "")
        return shown + (f" (mean of {self.tests} tests)" if self.tests > 1 else "")


def relative_error(simulated: Values, target: float) -> Values:
    """(y - r) / r, or the absolute error y - r where the target r is 0."""
    if target == 0.0:
        return simulated - target
    return (simulated - target) / target


def relative_miss(target: Target, simulated: float) -> float:
    """How far a response misses its target, relative to the value or the bound it passes
    (0 inside a target's bounds; the absolute miss where that reference is 0)."""
    return float(relative_error(simulated, float(target.nearest(simulated))))


def replicate_mean(values: list[float]) -> float:
    """Mean of the replicates of one response (Samuelsson 2023, sec. 2.5)."""
    return fmean(values)


def replicate_spread(values: list[float]) -> float:
    """Sample standard deviation of the replicates (0 for a single replicate)."""
    return stdev(values) if len(values) > 1 else 0.0


def objective_value(
    targets: list[Target], mean_responses: dict[str, float], form: str = DEFAULT_FORM
) -> float:
    """The objective of replicate-mean responses: eq. 3.3, or its precision-weighted form.

    ``mean_responses`` maps ``scene.response`` to the replicate mean.
    """
    total = float(objective_values(targets, mean_responses, form))
    if not math.isfinite(total):
        raise ValueError(f"objective is not finite ({total}); responses {mean_responses}")
    return total


def objective_values(
    targets: list[Target] | tuple[Target, ...],
    responses: Mapping[str, float | np.ndarray],
    form: str = DEFAULT_FORM,
) -> float | np.ndarray:
    """The objective of responses given as numbers or as arrays of one shape (element-wise).

    Used on simulated means and on model predictions or posterior samples.
    """
    total: float | np.ndarray = 0.0
    for t in targets:
        error = target_error(t, responses[t.key], form)
        total = total + t.weight * error * error
    return total


def target_error(
    target: Target, simulated: float | np.ndarray, form: str = DEFAULT_FORM
) -> float | np.ndarray:
    """The error of one response in the objective's form: (y - r) / r (Rackl & Hanley 2017, eq. 9;
    y - r where r is 0), or (y - r) / s in units of the target's spread (precision form)."""
    y = np.asarray(simulated, float)
    if target.is_band:
        reference = target.nearest(y)
        if form == PRECISION:
            assert target.spread is not None, "the study's config requires spreads for this form"
            scale = np.full(y.shape, target.spread)
        else:  # relative to the bound passed; absolute where that bound is 0
            scale = np.where(reference == 0.0, 1.0, np.abs(reference))
        gap: np.ndarray = (y - reference) / scale
        return gap
    if form == PRECISION:
        assert target.spread is not None, "the study's config requires spreads for this form"
        return (y - target.value) / target.spread
    return relative_error(y, target.value)


def weighted_residuals(
    targets: list[Target] | tuple[Target, ...],
    responses: Mapping[str, float | np.ndarray],
    form: str = DEFAULT_FORM,
) -> np.ndarray:
    """sqrt(w_i) e_i per target (rows): the residuals whose squares sum to the
    objective (least squares)."""
    return np.array(
        [math.sqrt(t.weight) * target_error(t, responses[t.key], form) for t in targets]
    )


@dataclass(frozen=True)
class ResponseObjective:
    """The study's objective as a function of responses: the one computation of it.

    The objective job scores an evaluation with it (``of_replicates``), the
    daemon takes each replicate's value for the optimizer's noise estimate
    (``per_replicate``) and early-termination estimates (``estimate``), and
    the optimizer applies it to its response data and its models'
    predictions (calling it). ``cost`` is the Rayleigh time-step term of the
    point (Rackl & Hanley 2017, eq. 10; ``Study.timestep_cost``), added to
    every value of that point.
    """

    targets: tuple[Target, ...]
    form: str = DEFAULT_FORM
    #: score an evaluation by the mean of its replicates' objectives, the expected loss
    #: (bias² + variance) over materials drawn per replicate, not by its mean responses
    expected_loss: bool = False

    def __post_init__(self) -> None:
        if self.form not in OBJECTIVE_FORMS:
            raise ValueError(f"objective form {self.form!r} is not one of {OBJECTIVE_FORMS}")

    def __call__(self, responses: Mapping[str, float | np.ndarray]) -> float | np.ndarray:
        return objective_values(self.targets, responses, self.form)

    @property
    def keys(self) -> list[str]:
        return [t.key for t in self.targets]

    @property
    def version(self) -> str:
        """A short fingerprint of the targets, weights, spreads and form: what an evaluation's
        objective record names as what it was scored against."""
        text = json.dumps(self.to_dict(), sort_keys=True, allow_nan=True)
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    def of_means(self, means: Mapping[str, float], cost: float = 0.0) -> float:
        """Eq. 3.3 (or its precision form) of replicate-mean responses, plus ``cost``."""
        return objective_value(list(self.targets), dict(means), self.form) + cost

    def of_replicates(self, replicates: Mapping[str, list[float]], cost: float = 0.0) -> float:
        """The objective of an evaluation: its replicates averaged per response first
        (Samuelsson 2023, sec. 2.5), then eq. 3.3, plus ``cost``; with ``expected_loss``, the
        mean of the replicates' own objectives. ValueError if not finite."""
        each = self.per_replicate(replicates, cost) if self.expected_loss else []
        if each:
            value = sum(each) / len(each)
            if not math.isfinite(value):
                raise ValueError(f"the replicates' objectives {each} are not all finite")
            return value
        return self.of_means({key: replicate_mean(v) for key, v in replicates.items()}, cost)

    def per_replicate(
        self, replicates: Mapping[str, list[float]], cost: float = 0.0
    ) -> list[float]:
        """The objective of each replicate index alone (see ``replicate_objectives``)."""
        return replicate_objectives(list(self.targets), dict(replicates), cost, self.form)

    def estimate(self, estimates: Mapping[str, list[float]], cost: float = 0.0) -> float | None:
        """The objective of a running evaluation from its early estimates
        (``estimated_objective``)."""
        return estimated_objective(list(self.targets), dict(estimates), cost, self.form)

    def to_dict(self) -> dict[str, Any]:
        return {
            "form": self.form,
            **({"expected_loss": True} if self.expected_loss else {}),
            "targets": [
                {
                    "scene": t.scene,
                    "response": t.response,
                    "value": t.value,
                    "weight": t.weight,
                    "spread": t.spread,
                    **bounds_of(t),
                    **band_terms_of(t),
                }
                for t in self.targets
            ],
        }

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> ResponseObjective:
        return cls(
            tuple(Target(**t) for t in record["targets"]),
            record["form"],
            record.get("expected_loss", False),
        )


def bounds_of(target: Target) -> dict[str, float]:
    """The bounds a target has, for a record (none for a plain target: its records stay as
    they were before bounds existed)."""
    return {
        name: bound
        for name, bound in (("lower", target.lower), ("upper", target.upper))
        if bound is not None
    }


def band_terms_of(target: Target) -> dict[str, float]:
    """The target's number of tests and discrepancy where not the defaults (1 and 0), for a
    record (records of targets without them stay as they were before they existed)."""
    return {
        name: term
        for name, term, default in (
            ("tests", target.tests, 1),
            ("discrepancy", target.discrepancy, 0.0),
        )
        if term != default
    }


def replicate_objectives(
    targets: list[Target],
    replicates: dict[str, list[float]],
    cost: float = 0.0,
    form: str = DEFAULT_FORM,
) -> list[float]:
    """Eq. 3.3 of each replicate index alone (for the optimizer's noise estimate).

    Empty unless every targeted response has the same number (> 1) of replicates.
    A non-finite replicate gives a non-finite value, for the caller to judge.
    """
    counts = {len(replicates.get(t.key, [])) for t in targets}
    if len(counts) != 1 or counts in ({0}, {1}):
        return []
    return [
        float(objective_values(targets, {t.key: replicates[t.key][i] for t in targets}, form))
        + cost
        for i in range(counts.pop())
    ]


def estimated_objective(
    targets: list[Target],
    estimates: dict[str, list[float]],
    cost: float = 0.0,
    form: str = DEFAULT_FORM,
) -> float | None:
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
            total += float(objective_values([t], {t.key: sum(values) / len(values)}, form))
            used += 1
    return total if used and math.isfinite(total) else None
