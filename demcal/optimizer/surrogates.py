"""Surrogate models behind one fit/predict interface, inputs in the unit box.

* :class:`CubicRBF` — the thesis' surrogate (Samuelsson 2023, eq. 2.10–2.11):
  cubic kernel phi(r) = r^3 with a linear tail, solved as one saddle-point
  system. A smoothing term on the kernel diagonal turns interpolation into
  regression for noisy objectives; its size is chosen by leave-one-out
  cross-validation with Rippa's (1999) closed form, and replicate spreads
  add to it per point.
* :class:`KrigingSurrogate` — SMT's KRG with a Matérn 5/2 kernel, a linear
  drift and an estimated nugget, as the universal Kriging of Rackl & Hanley
  (2017); it also predicts a standard deviation.
* :class:`SMTRadialBasis` — SMT's (Gaussian) RBF with a linear tail.

All share the same preparation of the training data: exact and
near-duplicate points are merged (their values averaged), constant data give
a constant model, and for the RBFs large objective values are capped at the
median (Björkman & Holmström 2000) so that a few penalised or failed-looking
values do not make the interpolant oscillate. Kriging gets the values
uncapped: its nugget estimate absorbs the artificial plateau as noise.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.spatial.distance import cdist

SMOOTHING_GRID = (0.0, 1e-4, 1e-3, 1e-2, 3e-2, 1e-1, 3e-1, 1.0)


@dataclass
class TrainingData:
    """Merged, scaled training data (values standardised to mean 0, sd 1)."""

    x: np.ndarray
    z: np.ndarray
    noise: np.ndarray  # variance of each merged value, in standardised units
    offset: float
    scale: float


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
    return np.minimum(y, np.median(y))


def prepare_training_data(
    x: np.ndarray,
    y: np.ndarray,
    variance: np.ndarray | None,
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
    (optional) the variance of each value, e.g. from replicates.
    """

    caps_large_values = True

    def __init__(self, duplicate_tolerance: float = 1e-7):
        self.duplicate_tolerance = duplicate_tolerance
        self.data: TrainingData | None = None
        self.constant = False

    def fit(self, x, y, variance=None) -> Surrogate:
        self.data = prepare_training_data(
            x, y, variance, self.duplicate_tolerance, self.caps_large_values
        )
        self.constant = bool(np.all(self.data.z == 0.0))
        if not self.constant:
            self._fit_standardised(self.data)
        return self

    def predict(self, x) -> np.ndarray:
        """Predicted objective values at the rows of ``x``."""
        x = np.atleast_2d(np.asarray(x, float))
        if self.constant:
            return np.full(len(x), self.data.offset)
        return self.data.offset + self.data.scale * self._predict_standardised(x)

    def predict_std(self, x) -> np.ndarray:
        """Predicted standard deviation (Kriging only)."""
        raise NotImplementedError(f"{type(self).__name__} does not predict a standard deviation")

    def _fit_standardised(self, data: TrainingData) -> None:
        raise NotImplementedError

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError


def cubic_rbf_system(x: np.ndarray, smoothing: np.ndarray) -> np.ndarray:
    """The saddle-point matrix of eq. 2.11 with phi(r) = r^3 and P = [x, 1].

    ``smoothing`` is added to the kernel diagonal (zero: interpolation).
    """
    n, d = x.shape
    tail = np.hstack([x, np.ones((n, 1))])
    system = np.zeros((n + d + 1, n + d + 1))
    system[:n, :n] = cdist(x, x) ** 3 + np.diag(smoothing)
    system[:n, n:] = tail
    system[n:, :n] = tail.T
    return system


def leave_one_out_errors(system: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Leave-one-out residuals of an RBF fit in closed form (Rippa 1999).

    With M the inverse of the eq. 2.11 matrix and c = M [z; 0], the residual
    at point i when it is left out of the fit is c_i / M_ii.
    """
    n = len(z)
    inverse = np.linalg.pinv(system, hermitian=True)
    coefficients = inverse[:, :n] @ z
    return coefficients[:n] / np.diag(inverse)[:n]


def choose_smoothing(x: np.ndarray, z: np.ndarray, noise: np.ndarray) -> float:
    """Smoothing from SMOOTHING_GRID with the smallest leave-one-out error.

    Errors count only at points below the largest value (capped values sit
    on an artificial plateau), and a larger smoothing must lower the error
    by more than 20 % to be preferred, so noise-free data stay interpolated.
    """
    informative = z < z.max()
    if informative.sum() < 3:
        return 0.0
    best_value, best_error = 0.0, np.inf
    for value in SMOOTHING_GRID:
        errors = leave_one_out_errors(cubic_rbf_system(x, value + noise), z)[informative]
        error = float(np.sqrt(np.mean(errors**2)))
        if error < 0.8 * best_error:
            best_value, best_error = value, error
    return best_value


class CubicRBF(Surrogate):
    """Cubic RBF with linear tail (Samuelsson 2023, eq. 2.10–2.11).

    ``smoothing``: "auto" (leave-one-out choice, see :func:`choose_smoothing`)
    or a fixed non-negative number; 0 with no replicate variance reproduces
    ``scipy.interpolate.RBFInterpolator(kernel="cubic", degree=1)``.
    """

    def __init__(self, duplicate_tolerance: float = 1e-7, smoothing: float | str = "auto"):
        super().__init__(duplicate_tolerance)
        self.smoothing = smoothing
        self.chosen_smoothing = 0.0

    def _fit_standardised(self, data: TrainingData) -> None:
        n, d = data.x.shape
        if n < d + 2:
            # Too few points for a unique linear tail: interpolate without smoothing choice.
            self.chosen_smoothing = 0.0 if self.smoothing == "auto" else float(self.smoothing)
        elif self.smoothing == "auto":
            self.chosen_smoothing = choose_smoothing(data.x, data.z, data.noise)
        else:
            self.chosen_smoothing = float(self.smoothing)
        system = cubic_rbf_system(data.x, self.chosen_smoothing + data.noise)
        right_side = np.concatenate([data.z, np.zeros(d + 1)])
        try:
            solution = np.linalg.solve(system, right_side)
        except np.linalg.LinAlgError:
            solution = np.linalg.lstsq(system, right_side, rcond=None)[0]
        self.weights = solution[:n]
        self.tail = solution[n:]

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        kernel = cdist(x, self.data.x) ** 3
        return kernel @ self.weights + x @ self.tail[:-1] + self.tail[-1]


#: A Kriging nugget (relative to the process variance) this large leaves only the trend.
DEGENERATE_NUGGET = 1e6
#: The nugget search starts at least here (a start at ~0 stays at an interpolating fit).
NUGGET_START_MIN = 1e-6


class KrigingSurrogate(Surrogate):
    """Universal Kriging (Rackl & Hanley 2017): SMT KRG, Matérn 5/2, linear drift, nugget.

    The nugget (``eval_noise``) is estimated by maximum likelihood; the mean
    replicate variance, when given, is its starting value. A ``warm_start``
    (length scales, nugget) of a previous fit starts the search there instead.
    """

    caps_large_values = False  # capping plus a nugget made the fit mostly trend and noise

    def __init__(
        self,
        duplicate_tolerance: float = 1e-7,
        restarts: int = 5,
        seed: int = 0,
        warm_start: tuple[np.ndarray, float] | None = None,
    ):
        super().__init__(duplicate_tolerance)
        self.restarts = restarts
        self.seed = seed
        #: start of the hyperparameter search, (length scales, nugget): a previous fit's optimum
        self.start = warm_start

    def _fit_standardised(self, data: TrainingData) -> None:
        from smt.surrogate_models import KRG

        n, d = data.x.shape
        trend = "linear" if n > 2 * (d + 1) else "constant"
        self.model = KRG(
            corr="matern52",
            poly=trend,
            eval_noise=True,
            noise0=[
                max(
                    float(np.mean(data.noise)) if self.start is None else self.start[1],
                    NUGGET_START_MIN,
                )
            ],
            hyper_opt="Cobyla",
            n_start=self.restarts,
            seed=self.seed,
            print_global=False,
            **(
                {}
                if self.start is None or len(self.start[0]) != d
                else {"theta0": list(self.start[0])}
            ),
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self.model.set_training_values(data.x, data.z)
            self.model.train()

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return self.model.predict_values(x).ravel()

    @property
    def warm_start(self) -> tuple[np.ndarray, float] | None:
        """(length scales, nugget) of this fit, to start the next fit from; None when there is
        nothing to start from or the fit is degenerate (a nugget so large that only the trend
        is left: a start there stays there)."""
        if self.constant:
            return None
        nugget = float(np.ravel(self.model.optimal_noise)[0])
        if nugget >= DEGENERATE_NUGGET:
            return None
        return np.asarray(self.model.optimal_theta, float), nugget

    def predict_std(self, x) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, float))
        if self.constant:
            return np.zeros(len(x))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            variance = self.model.predict_variances(x).ravel()
        return self.data.scale * np.sqrt(np.maximum(variance, 0.0))


class SMTRadialBasis(Surrogate):
    """SMT's RBF: Gaussian kernel of width ``d0`` (unit box) plus a linear tail."""

    def __init__(self, duplicate_tolerance: float = 1e-7, width: float = 0.5):
        super().__init__(duplicate_tolerance)
        self.width = width

    def _fit_standardised(self, data: TrainingData) -> None:
        from smt.surrogate_models import RBF

        self.model = RBF(d0=self.width, poly_degree=1, reg=1e-10, print_global=False)
        self.model.set_training_values(data.x, data.z)
        self.model.train()

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        return self.model.predict_values(x).ravel()


#: The scalar surrogates by their settings name: (duplicate_tolerance, restarts, seed) -> model.
SURROGATE_MODELS = {
    "cubic_rbf": lambda tolerance, restarts, seed: CubicRBF(tolerance),
    "kriging": lambda tolerance, restarts, seed: KrigingSurrogate(
        tolerance, restarts=restarts, seed=seed
    ),
    "smt_rbf": lambda tolerance, restarts, seed: SMTRadialBasis(tolerance),
}


def make_surrogate(
    name: str, duplicate_tolerance: float, restarts: int = 5, seed: int = 0
) -> Surrogate:
    """The surrogate named in the settings (a key of ``SURROGATE_MODELS``)."""
    return SURROGATE_MODELS[name](duplicate_tolerance, restarts, seed)
