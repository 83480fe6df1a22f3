"""Whether a parameter set meets the targets: the acceptance band of each target and the
probability, under the response models, that a point lies inside every band.

The statistical model (docs/solutions.md): a measured value is the true lab response plus the
error of its mean (its standard error, spread / sqrt(tests)); the true lab response is the
noise-free simulated one plus a model discrepancy the user may give. A point belongs to the set
where its noise-free response lies within k of those combined sd of the value. The scatter of
single simulations is not in the band (unless a target has no spread to judge it by): it is in
the models' uncertainty about the noise-free response. The probability integrates each model's
normal prediction over its band (level-set estimation, Bryan et al. 2005). The solution-map
strategy samples where it is most uncertain; the analysis of a finished calibration
(`demcal.analysis.solutions`) reads the set off it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import norm

from demcal.optimizer.objective import Target

#: Half-width of the acceptance band in combined sd: the default k of the report and the mapping.
BAND_SD = 2.0
#: What the band's sd combines, in the words of the commands that print a set.
BAND_WORDS = "each target's standard error and model discrepancy"
#: Membership probabilities: at least POSSIBLE, the models cannot rule a point out; at least
#: LIKELY, it belongs to the estimate of the set; at least SURE, its membership is decided.
POSSIBLE, LIKELY, SURE = 0.05, 0.5, 0.95


def band_sd(target: Target, noise_sd: float) -> float:
    """The sd a noise-free simulated response may miss the target's value by at the right
    parameters: the value's standard error and the model discrepancy, combined. A target with
    no spread has no measured scatter: the scatter of single simulations (``noise_sd``) takes
    the standard error's place."""
    error = target.standard_error if target.spread else noise_sd
    return math.hypot(error, target.discrepancy)


def tolerance_sd(target: Target, noise_sd: float, model_sd: float | np.ndarray) -> np.ndarray:
    """The combined standard deviation a prediction may miss its target by, per point:
    sqrt(band sd² + model sd²), `band_sd` and the model's uncertainty about the noise-free
    response there."""
    return np.sqrt(band_sd(target, noise_sd) ** 2 + np.asarray(model_sd) ** 2)


def band_half_width(target: Target, noise_sd: float, k: float) -> float:
    """How far a noise-free response may lie from its target and still meet it: k `band_sd`."""
    return k * band_sd(target, noise_sd)


def membership_probability(
    targets: tuple[Target, ...],
    means: dict[str, np.ndarray],
    stds: dict[str, np.ndarray],
    noise_sd: dict[str, float],
    k: float,
) -> np.ndarray:
    """The probability, per point, that every response meets its target within ``k`` band sd.

    Each response's noise-free value is normal with the model's predicted
    mean and sd (the model's own uncertainty, independent between
    responses), and must lie within `band_half_width` of the target. Near 1 where the
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
