"""Particle size distributions: truncated lognormal given by d50 and sigma_ln."""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import truncnorm


def diameter_range(d50: float, sigma_ln: float, truncation: float) -> tuple[float, float]:
    """Smallest and largest diameter [m]: d50 exp(-+ k sigma_ln)."""
    spread = math.exp(truncation * sigma_ln)
    return d50 / spread, d50 * spread


def sample_diameters(count: int, d50: float, sigma_ln: float, truncation: float,
                     rng: np.random.Generator) -> np.ndarray:
    """``count`` diameters [m] with ln(d) ~ N(ln d50, sigma_ln^2) cut at +-truncation sigma.

    sigma_ln = 0 gives a monodisperse packing of d50. The distribution is by
    number of particles.
    """
    if sigma_ln == 0.0:
        return np.full(count, d50)
    z = truncnorm.rvs(-truncation, truncation, size=count, random_state=rng)
    return d50 * np.exp(sigma_ln * z)
