"""Mapping the solution set: points where membership in it is least certain (level-set estimation).

Once the answer is known, the parameter sets that meet every target as well
may still be a whole family (Rackl & Hanley 2017, sec. 3.1). To map it, each
new point goes where the response models are least able to say whether it
belongs: the membership probability p of
:func:`demcal.analysis.solutions.membership_probability` is nearest 1/2,
scored by p (1 − p), the straddle of Bryan et al. (2005) on a probability
scale. Regions no simulation has reached have a large model sd and so a p
between 0 and 1; the set's sharp, well-simulated parts have p near 0 or 1
and are left alone. Running points repel new ones, so P workers spread out.
"""

from __future__ import annotations

import numpy as np

from demcal.optimizer.membership import BAND_SD, membership_probability
from demcal.results.records import Status

from .. import candidates as st
from .base import History, Strategy

#: Uniform candidates scored per proposal, per parameter (predictions are cheap).
CANDIDATES_PER_PARAMETER = 1000


class SolutionMap(Strategy):
    """The candidate of most uncertain membership in the solution set (see the module)."""

    def propose(self, history: History) -> np.ndarray:
        predictor = history.responses
        if predictor is None:
            return history.space_filling_point()
        candidates = st.uniform_candidates(
            CANDIDATES_PER_PARAMETER * history.dimension, history.dimension, history.rng
        )
        candidates = candidates[history.admissible(candidates)]
        if not len(candidates):
            return history.space_filling_point()
        means, stds = predictor.predict(candidates)
        noise = {key: model.noise_sd for key, model in predictor.models.items()}
        p = membership_probability(predictor.objective.targets, means, stds, noise, BAND_SD)
        score = (
            p
            * (1.0 - p)
            * st.pending_damping(candidates, history.select(Status.PENDING), history.sigma)
        )
        chosen: np.ndarray = candidates[int(np.argmax(score))]
        return chosen
