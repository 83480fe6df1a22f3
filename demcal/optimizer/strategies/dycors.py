"""MSRS/DYCORS (Samuelsson 2023, Algorithm 4): perturbation candidates scored by weighted
surrogate value and distance."""

from __future__ import annotations

import numpy as np

from .. import candidates as st
from .base import CandidateSearch, History


class Dycors(CandidateSearch):
    """MSRS/DYCORS: lowest weighted score of surrogate value and distance (Algorithm 4, steps c–e).

    With ``polish_candidate``, the surrogate minimum is taken as it is at
    the most exploitative weight and in the last ``final_exploitation``
    share of the budget.
    """

    def choose(
        self, history: History, candidates: np.ndarray, weight: float, polished: bool
    ) -> np.ndarray:
        s, surrogate = history.settings, history.surrogate
        assert surrogate is not None, "a candidate search chooses only with a surrogate"
        final = history.handed_out >= s.max_evaluations * (1.0 - s.final_exploitation)
        if polished and (weight == max(s.weights) or final):
            polish: np.ndarray = candidates[-1]
            return polish
        scores = st.weighted_scores(
            surrogate.predict(candidates),
            st.nearest_distances(candidates, history.points),
            weight,
        )
        chosen: np.ndarray = candidates[int(np.argmin(scores))]
        return chosen
