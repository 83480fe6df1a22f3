"""Whether a parameter set meets the targets: the acceptance band of each target and the
probability, under the response models, that a point lies inside every band.

The band is k combined standard deviations of the target's measured spread and the scatter of
single simulations; the probability integrates each model's normal prediction over its band
(level-set estimation, Bryan et al. 2005). The solution-map strategy samples where it is most
uncertain; the analysis of a finished calibration (`demcal.analysis.solutions`) reads the set
off it.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import norm

from demcal.optimizer.objective import Target

#: Half-width of the acceptance band in combined sd: the default k of the report and the mapping.
BAND_SD = 2.0
#: Membership probabilities: at least POSSIBLE, the models cannot rule a point out; at least
#: LIKELY, it belongs to the estimate of the set; at least SURE, its membership is decided.
POSSIBLE, LIKELY, SURE = 0.05, 0.5, 0.95


def tolerance_sd(target: Target, noise_sd: float, model_sd: float | np.ndarray) -> np.ndarray:
    """The combined standard deviation a prediction may miss its target by, per point.

    sqrt(spread² + noise² + model sd²): the measurement spread of the target,
    the scatter of single simulations, and the model's uncertainty there.
    """
    spread = target.spread or 0.0
    return np.sqrt(spread**2 + noise_sd**2 + np.asarray(model_sd) ** 2)


def band_half_width(target: Target, noise_sd: float, k: float) -> float:
    """How far a noise-free response may lie from its target and still meet it: k combined sd
    of the target's spread and the simulation noise (`tolerance_sd` without the model
    term)."""
    return float(k * tolerance_sd(target, noise_sd, 0.0))


def membership_probability(
    targets: tuple[Target, ...],
    means: dict[str, np.ndarray],
    stds: dict[str, np.ndarray],
    noise_sd: dict[str, float],
    k: float,
) -> np.ndarray:
    """The probability, per point, that every response meets its target within ``k`` sd.

    Each response's noise-free value is normal with the model's predicted
    mean and sd (the model's own uncertainty, independent between
    responses), and must lie within k sqrt(spread² + noise²) of the target
    (`tolerance_sd` without the model term). Near 1 where the
    simulations show the point meets every target, near 0 where they rule
    it out, and in between where no simulation has been near enough to say:
    the membership a level-set estimation maps (Bryan et al. 2005).
    """
    probability: np.ndarray | None = None
    for t in targets:
        half_width = band_half_width(t, noise_sd[t.key], k)
        mean, sd = np.asarray(means[t.key], float), np.asarray(stds[t.key], float)
        low, high = t.accepted(half_width)
        inside = ((low <= mean) & (mean <= high)).astype(float)
        with np.errstate(divide="ignore", invalid="ignore"):
            spread = norm.cdf((high - mean) / sd) - norm.cdf((low - mean) / sd)
        p: np.ndarray = np.where(sd > 0.0, spread, inside)
        probability = p if probability is None else probability * p
    assert probability is not None, "an objective has at least one target"
    return probability
