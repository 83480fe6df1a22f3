"""The cubic RBF with a linear tail (Samuelsson 2023, eq. 2.10–2.11), and its response variant.

The kernel phi(r) = r^3 with a linear tail is solved as one saddle-point
system. A smoothing term on the kernel diagonal turns interpolation into
regression for noisy objectives; its size is chosen by leave-one-out
cross-validation with Rippa's (1999) closed form, and replicate spreads add
to it per point. :class:`ResponseRBF` models a response: uncapped, with the
leave-one-out error as its standard deviation.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.distance import cdist

from .base import ResponseModel, Surrogate, TrainingData

SMOOTHING_GRID = (0.0, 1e-4, 1e-3, 1e-2, 3e-2, 1e-1, 3e-1, 1.0)


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
    errors: np.ndarray = coefficients[:n] / np.diag(inverse)[:n]
    return errors


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
        assert self.data is not None, "a surrogate predicts once fitted"
        kernel: np.ndarray = cdist(x, self.data.x) ** 3
        values: np.ndarray = kernel @ self.weights + x @ self.tail[:-1] + self.tail[-1]
        return values


class ResponseRBF(CubicRBF, ResponseModel):
    """The cubic RBF for a response: values uncapped, and a standard deviation.

    The standard deviation is the root mean square of the leave-one-out
    errors (Rippa 1999), the same everywhere: a rough but honest measure
    of how well the interpolant predicts a point it has not seen.
    """

    def _fit_standardised(self, data: TrainingData) -> None:
        super()._fit_standardised(data)
        n, d = data.x.shape
        if n >= d + 2:
            system = cubic_rbf_system(data.x, self.chosen_smoothing + data.noise)
            self.loo_rms = float(np.sqrt(np.mean(leave_one_out_errors(system, data.z) ** 2)))
        else:
            self.loo_rms = 1.0  # too few points to judge: one standard deviation of the data

    def predict_std(self, x: ArrayLike) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, float))
        if self.constant:
            return np.zeros(len(x))
        assert self.data is not None, "a surrogate predicts once fitted"
        return np.full(len(x), self.data.scale * self.loo_rms)
