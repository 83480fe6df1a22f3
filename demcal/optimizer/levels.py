"""When a cheaper fidelity level pays, and which level the next simulation runs at.

**Does the level pay?** For two models whose single runs correlate with r and cost
w = cost(cheap) / cost(fine), the variance of the best two-model estimator relative to fine
runs alone at the same budget is (sqrt(1 - r²) + sqrt(r² w))² (Peherstorfer, Willcox &
Gunzburger 2016, multifidelity Monte Carlo with two models). A level pays when that ratio, at
the one-sided 90 % lower bound of r (Fisher's z), is below 1. ``demcal fidelity check``
applies the rule to its paired runs; a calibration applies it to each response as its data
grow (:func:`pays`), and models a response from fine runs alone where the level does not pay.

**Which level next?** At the point the strategy chose, a run at level l is worth
``corr_l * (1 - tau_l / sqrt(s_l² + tau_l²)) / cost_l`` per CPU second: the augmented
expected improvement's factors (Huang, Allen, Notz & Miller 2006) without the common
expected improvement: how much a run at l tells about the fine response (the posterior
correlation corr_l of y_l(x) and y_fine(x); 1 for fine), how much it reduces the uncertainty
at all given its noise tau_l, per CPU second. Summed over the responses a cheap run informs
(a response where the level does not pay gains nothing from it), the cheaper level is chosen
when it is worth more than a fine run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from scipy import stats

#: One-sided confidence of the correlation's lower bound that the rule uses.
CONFIDENCE = 0.9
#: Fewest paired points a verdict needs (Fisher's z needs n > 3).
MIN_POINTS = 4


def correlation_lower_bound(r: float, n: int, confidence: float = CONFIDENCE) -> float:
    """The one-sided lower confidence bound of a correlation ``r`` of ``n`` pairs (Fisher's z:
    atanh(r) is about normal with sd 1 / sqrt(n - 3)); nan for n <= 3."""
    if n <= 3 or not math.isfinite(r):
        return math.nan
    z = math.atanh(min(max(r, -0.999999), 0.999999))
    return math.tanh(z - float(stats.norm.ppf(confidence)) / math.sqrt(n - 3))


def variance_ratio(r: float, cost_ratio: float) -> float:
    """Variance of the two-model multifidelity estimator relative to fine runs alone at the
    same budget, (sqrt(1 - r²) + sqrt(r² w))² (Peherstorfer et al. 2016); nan where r or the
    cost ratio w is unknown. A correlation at or below 0 helps nothing: 1."""
    if not (math.isfinite(r) and math.isfinite(cost_ratio)):
        return math.nan
    if r <= 0.0:
        return 1.0
    return (math.sqrt(1.0 - r * r) + math.sqrt(r * r * cost_ratio)) ** 2


def ratio_pays(ratio: float) -> bool:
    """Whether a variance ratio (:func:`variance_ratio`) is a saving: finite and below 1."""
    return math.isfinite(ratio) and ratio < 1.0


def pays(r: float, n: int, cost_ratio: float) -> bool:
    """The rule: the variance ratio at the lower bound of ``r`` over ``n`` pairs is below 1."""
    return ratio_pays(variance_ratio(correlation_lower_bound(r, n), cost_ratio))


@dataclass(frozen=True)
class LevelOutlook:
    """What a run at a level would tell about one response at a point: the posterior
    correlation of the level's value there with the fine one, the level's predictive sd and
    its noise sd (response units)."""

    correlation: float
    sd: float
    noise_sd: float

    def information(self) -> float:
        """corr * (1 - tau / sqrt(s² + tau²)): the augmented expected improvement's factors."""
        total = math.sqrt(self.sd**2 + self.noise_sd**2)
        if total == 0.0:
            return 0.0
        return max(self.correlation, 0.0) * (1.0 - self.noise_sd / total)


def cheap_is_worth_more(
    fine: Sequence[LevelOutlook], cheap: Sequence[LevelOutlook | None], cost_ratio: float
) -> bool:
    """Whether a run at the cheaper level is worth more per CPU second than a fine one, summed
    over the responses (``cheap`` None: the level tells nothing about that response)."""
    if not (math.isfinite(cost_ratio) and cost_ratio > 0.0):
        return False
    worth_fine = sum(outlook.information() for outlook in fine)
    worth_cheap = sum(o.information() for o in cheap if o is not None) / cost_ratio
    return worth_cheap > worth_fine
