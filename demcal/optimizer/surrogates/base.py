"""What every surrogate shares: the fit/predict interface and the preparation of its data.

A surrogate is fitted on points in the unit box and their values; an
objective surrogate (:class:`Surrogate`, :data:`~..registry.SURROGATES`)
models the objective, a response model (:class:`ResponseModel`,
:data:`~..registry.RESPONSE_MODELS`) one response and also predicts its
standard deviation. Every model gets the same preparation of its training
data: exact and near-duplicate points are merged (their values averaged),
constant data give a constant model, and large objective values are capped
at the median (Björkman & Holmström 2000) where a model asks for it, so
that a few penalised or failed-looking values do not make an interpolant
oscillate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Self

import numpy as np
from numpy.typing import ArrayLike


@dataclass
class TrainingData:
    """Merged, scaled training data (values standardised to mean 0, sd 1)."""

    x: np.ndarray
    z: np.ndarray
    noise: np.ndarray  # variance of each merged value, in standardised units
    offset: float
    scale: float


@dataclass(frozen=True)
class HyperparameterSearch:
    """How a model that searches its hyperparameters (Kriging) is to search: ``restarts`` starts
    drawn with ``seed``, and ``warm_start``, a previous fit's optimum to start from (or None)."""

    restarts: int
    seed: int
    warm_start: tuple[np.ndarray, float] | None


def merge_duplicates(
    x: np.ndarray, y: np.ndarray, variance: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge points closer than ``tolerance`` into their mean.

    An exact duplicate makes the RBF system singular and a near-duplicate
    makes it ill-conditioned (silently wrong coefficients), so each group is
    replaced by the mean location and mean value; the variance of a mean of
    k values is the mean variance divided by k.
    """
    x = np.asarray(x, float)
    group = -np.ones(len(x), dtype=int)
    groups = 0
    for i in range(len(x)):
        if group[i] >= 0:
            continue
        close = np.linalg.norm(x - x[i], axis=1) <= tolerance
        group[close & (group < 0)] = groups
        groups += 1
    counts = np.bincount(group, minlength=groups).astype(float)
    merged_x = np.stack([x[group == g].mean(axis=0) for g in range(groups)])
    merged_y = np.bincount(group, weights=y, minlength=groups) / counts
    merged_variance = np.bincount(group, weights=variance, minlength=groups) / counts**2
    return merged_x, merged_y, merged_variance


def cap_at_median(y: np.ndarray) -> np.ndarray:
    """Replace values above the median by the median (Björkman & Holmström 2000).

    Keeps the surrogate's attention on the low (interesting) region and
    bounds the influence of penalised values.
    """
    capped: np.ndarray = np.minimum(y, np.median(y))
    return capped


def prepare_training_data(
    x: ArrayLike,
    y: ArrayLike,
    variance: ArrayLike | None,
    duplicate_tolerance: float,
    cap_values: bool = True,
) -> TrainingData:
    """Merge duplicates, cap large values and standardise the values."""
    x = np.atleast_2d(np.asarray(x, float))
    y = np.asarray(y, float).ravel()
    variance = np.zeros(len(y)) if variance is None else np.asarray(variance, float).ravel()
    if len(x) != len(y) or len(y) != len(variance):
        raise ValueError("x, y and variance must have the same number of points")
    x, y, variance = merge_duplicates(x, y, variance, duplicate_tolerance)
    if cap_values:
        y = cap_at_median(y)
    offset = float(np.mean(y))
    spread = float(np.std(y))
    scale = spread if spread > 1e-12 * max(1.0, abs(offset)) else 1.0
    return TrainingData(x, (y - offset) / scale, variance / scale**2, offset, scale)


class Surrogate:
    """Common interface: ``fit(x, y, variance)`` then ``predict(x)``.

    ``x`` is in the unit box, ``y`` the objective values and ``variance``
    (optional) the variance of each value, e.g. from replicates. Subclasses
    implement ``_fit_standardised`` and ``_predict_standardised`` on the
    prepared data; :meth:`create` builds one from the optimizer's settings.
    """

    caps_large_values = True

    def __init__(self, duplicate_tolerance: float = 1e-7):
        self.duplicate_tolerance = duplicate_tolerance
        self.data: TrainingData | None = None
        self.constant = False

    @classmethod
    def create(
        cls,
        duplicate_tolerance: float,
        restarts: int = 5,
        seed: int = 0,
        warm_start: tuple[np.ndarray, float] | None = None,
    ) -> Self:
        """The model as the optimizer makes it: ``restarts``, ``seed`` and ``warm_start`` are the
        :class:`HyperparameterSearch` it is made :meth:`searching` with."""
        return cls.searching(duplicate_tolerance, HyperparameterSearch(restarts, seed, warm_start))

    @classmethod
    def searching(cls, duplicate_tolerance: float, search: HyperparameterSearch) -> Self:
        """The model with ``search`` for its hyperparameters; models without hyperparameters to
        search (all but Kriging) ignore it."""
        return cls(duplicate_tolerance)

    def fit(self, x: ArrayLike, y: ArrayLike, variance: ArrayLike | None = None) -> Self:
        self.data = prepare_training_data(
            x, y, variance, self.duplicate_tolerance, self.caps_large_values
        )
        self.constant = bool(np.all(self.data.z == 0.0))
        if not self.constant:
            self._fit_standardised(self.data)
        return self

    def predict(self, x: ArrayLike) -> np.ndarray:
        """Predicted objective values at the rows of ``x``."""
        x = np.atleast_2d(np.asarray(x, float))
        assert self.data is not None, "a surrogate predicts once fitted"
        if self.constant:
            return np.full(len(x), self.data.offset)
        return self.data.offset + self.data.scale * self._predict_standardised(x)

    def predict_std(self, x: ArrayLike) -> np.ndarray:
        """Predicted standard deviation (Kriging only)."""
        raise NotImplementedError(f"{type(self).__name__} does not predict a standard deviation")

    def _fit_standardised(self, data: TrainingData) -> None:
        raise NotImplementedError

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class ResponseModel(Surrogate):
    """A model of one response: values uncapped, and a standard deviation (:meth:`predict_std`).

    ``warm_start``: what the next fit of the same response may start from
    (None: nothing, the default).
    """

    caps_large_values = False
    #: variance of the model's data that its noise term may not fall below (response units²)
    noise_floor = 0.0

    def fit(
        self,
        x: ArrayLike,
        y: ArrayLike,
        variance: ArrayLike | None = None,
        noise_floor: float = 0.0,
    ) -> Self:
        """As :meth:`Surrogate.fit`; ``noise_floor``: the scatter of the data measured from
        replicates (variance), below which a model with a noise term (Kriging) keeps its
        estimate, so that no prediction is surer than the simulations it rests on."""
        self.noise_floor = noise_floor
        return super().fit(x, y, variance)

    @property
    def noise_sd(self) -> float:
        """The scatter of the data about the model that the fit attributes to noise (response
        units); 0 for a model without a noise term."""
        return 0.0

    @property
    def warm_start(self) -> tuple[np.ndarray, float] | None:
        return None
