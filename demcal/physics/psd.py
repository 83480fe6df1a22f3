"""Particle size distributions: truncated lognormal given by d50 and sigma_ln."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ndtr


def diameter_range(d50: float, sigma_ln: float, truncation: float) -> tuple[float, float]:
    """Smallest and largest diameter [m]: d50 exp(-+ k sigma_ln)."""
    spread = math.exp(truncation * sigma_ln)
    return d50 / spread, d50 * spread


def truncated_standard_normal(
    count: int, truncation: float, rng: np.random.Generator
) -> np.ndarray:
    """``count`` draws of N(0, 1) restricted to [-truncation, truncation] (rejection sampling)."""
    out = np.empty(0)
    while len(out) < count:
        z = rng.standard_normal(2 * (count - len(out)) + 16)
        out = np.concatenate([out, z[np.abs(z) <= truncation]])
    return out[:count]


def sample_diameters(
    count: int, d50: float, sigma_ln: float, truncation: float, rng: np.random.Generator
) -> np.ndarray:
    """``count`` diameters [m] with ln(d) ~ N(ln d50, sigma_ln^2) cut at +-truncation sigma.

    sigma_ln = 0 gives a monodisperse packing of d50. The distribution is by
    number of particles.
    """
    if sigma_ln == 0.0:
        return np.full(count, d50)
    return d50 * np.exp(sigma_ln * truncated_standard_normal(count, truncation, rng))


def mean_sphere_volume(d50: float, sigma_ln: float, truncation: float) -> float:
    """Expected volume [m^3] of one sphere of the truncated lognormal PSD (by number).

    With ln d ~ N(ln d50, s^2) cut at +-k s: E[d^3] = d50^3 exp(4.5 s^2)
    (Phi(k - 3 s) - Phi(-k - 3 s)) / (Phi(k) - Phi(-k)).
    """
    k, s = truncation, sigma_ln
    moment = math.exp(4.5 * s * s) * (ndtr(k - 3 * s) - ndtr(-k - 3 * s)) / (ndtr(k) - ndtr(-k))
    return float(math.pi / 6.0 * d50**3 * moment)


def sampled_q3(d: np.ndarray, d50: float, sigma_ln: float, truncation: float) -> np.ndarray:
    """Mass fraction finer than ``d`` (Q3) of the spheres :func:`sample_diameters` draws.

    With z = ln(d / d50) / sigma_ln, the number density is the standard normal's
    phi(z) on [-k, k]; weighted by d^3 ~ exp(3 sigma_ln z) it becomes phi(z - 3 sigma_ln),
    so Q3 = (Phi(z - 3 sigma_ln) - Phi(-k - 3 sigma_ln)) / (Phi(k - 3 sigma_ln) -
    Phi(-k - 3 sigma_ln)) with z clipped to [-k, k]. ``d`` and ``d50`` in one unit.
    """
    shift = 3.0 * sigma_ln
    z = np.clip(np.log(d / d50) / sigma_ln, -truncation, truncation)
    low, high = ndtr(-truncation - shift), ndtr(truncation - shift)
    return np.asarray((ndtr(z - shift) - low) / (high - low))
