"""Two-parameter distribution functions fitted to sieve data (Richter & Will 2021, sec. 3.3).

A sieve analysis gives pairs (d_i, Q3(d_i)): the aperture of sieve i and the
cumulative mass fraction passing it. Richter & Will describe a material's
particle-size distribution by one of three cumulative functions, each with a
size and a shape parameter:

- GGS (Gates–Gaudin–Schumann, their eq. 1): Q3(d) = (d / d_max)^k, 1 above d_max;
- RRSB (Rosin–Rammler–Sperling–Bennet, eq. 2): Q3(d) = 1 - exp(-(d / d63)^n);
- LOGN (lognormal, eq. 3): Q3(d) = 1/2 + 1/2 erf((ln d - ln d50) / (sqrt(2) sigma_ln)).

Sizes are in the unit of the sieve apertures given; Q3 is a fraction in [0, 1].
Each function is fitted by nonlinear least squares on Q3, started from the
straight line its linearised form (in ln d) fits through the sieves with
0 < Q3 < 1. Q3 is by mass; demcal's scenes sample diameters by number
(:mod:`demcal.physics.psd`), so their ``d50`` is :func:`number_median` of the
LOGN fit's d50.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import curve_fit
from scipy.special import erf, ndtri


def ggs(d: np.ndarray, d_max: float, k: float) -> np.ndarray:
    """Gates–Gaudin–Schumann (Richter & Will 2021, eq. 1): (d / d_max)^k, 1 above d_max."""
    return np.asarray(np.minimum(d / d_max, 1.0) ** k)


def rrsb(d: np.ndarray, d63: float, n: float) -> np.ndarray:
    """Rosin–Rammler–Sperling–Bennet (Richter & Will 2021, eq. 2): 1 - exp(-(d / d63)^n)."""
    return np.asarray(1.0 - np.exp(-((d / d63) ** n)))


def logn(d: np.ndarray, d50: float, sigma_ln: float) -> np.ndarray:
    """Lognormal (Richter & Will 2021, eq. 3) with ln d50 = mu_ln: Q3 at d."""
    return np.asarray(0.5 + 0.5 * erf(np.log(d / d50) / (math.sqrt(2.0) * sigma_ln)))


@dataclass(frozen=True)
class Function:
    """One distribution function: its size parameter's name, its shape parameter's name, the
    transform g(Q3) that is linear in ln d, and whether the shape is that line's slope (else
    its inverse)."""

    name: str
    cdf: Callable[[np.ndarray, float, float], np.ndarray]
    size: str
    shape: str
    linearised: Callable[[np.ndarray], np.ndarray]
    shape_is_slope: bool


#: The three functions of Richter & Will (2021), eqs. 1–3.
FUNCTIONS = (
    Function("GGS", ggs, "d_max", "k", np.log, True),
    Function("RRSB", rrsb, "d63", "n", lambda q: np.log(-np.log1p(-q)), True),
    Function("LOGN", logn, "d50", "sigma_ln", ndtri, False),
)


@dataclass(frozen=True)
class Fit:
    """One function fitted to sieve data: its size (unit of the apertures) and shape
    parameters, the coefficient of determination and the mean squared error of Q3."""

    function: str
    size_name: str
    size: float
    shape_name: str
    shape: float
    r2: float
    mse: float


def fit(function: Function, d: np.ndarray, q: np.ndarray) -> Fit:
    """Least-squares fit of ``function`` to apertures ``d`` (> 0) and fractions passing ``q``.

    Needs at least two sieves with different 0 < q < 1 (checked by the caller).
    """
    inner = (q > 0.0) & (q < 1.0)
    slope, intercept = np.polyfit(np.log(d[inner]), function.linearised(q[inner]), 1)
    start = (-intercept / slope, slope if function.shape_is_slope else 1.0 / slope)

    def model(x: np.ndarray, log_size: float, shape: float) -> np.ndarray:
        return function.cdf(x, math.exp(log_size), shape)

    (log_size, shape), _ = curve_fit(
        model, d, q, p0=start, bounds=([-np.inf, 0.0], [np.inf, np.inf])
    )
    fitted = model(d, log_size, shape)
    mse = float(np.mean((q - fitted) ** 2))
    return Fit(
        function.name,
        function.size,
        math.exp(log_size),
        function.shape,
        float(shape),
        r_squared(q, fitted),
        mse,
    )


def r_squared(q: np.ndarray, fitted: np.ndarray) -> float:
    """Coefficient of determination of ``fitted`` against the measured ``q``."""
    return 1.0 - float(((q - fitted) ** 2).sum() / ((q - q.mean()) ** 2).sum())


def fit_all(d: np.ndarray, q: np.ndarray) -> list[Fit]:
    """GGS, RRSB and LOGN fitted to the sieve data, best (lowest MSE, highest R²) first."""
    return sorted((fit(f, d, q) for f in FUNCTIONS), key=lambda f: f.mse)


def number_median(mass_median: float, sigma_ln: float) -> float:
    """The number median of a lognormal whose mass (Q3) median is ``mass_median``.

    Weighting a lognormal by d^3 shifts ln d by 3 sigma_ln^2 and keeps sigma_ln,
    so d50 by number = d50 by mass x exp(-3 sigma_ln^2).
    """
    return mass_median * math.exp(-3.0 * sigma_ln**2)
