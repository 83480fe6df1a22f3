"""Expected improvement on a Kriging surrogate (Samuelsson 2023, sec. 2.2.2.3): perturbation
and uniform candidates, damped within sigma of running points."""

from __future__ import annotations

import numpy as np

from demcal.results.records import Status

from .. import candidates as st
from .base import CandidateSearch, History


class KrigingEI(CandidateSearch):
    """Highest expected improvement over the best prediction, damped within sigma of running
    points."""

    def candidates(self, history: History, center: np.ndarray) -> np.ndarray:
        perturbed = super().candidates(history, center)
        uniform = st.uniform_candidates(history.settings.candidates, history.dimension, history.rng)
        return np.vstack([perturbed, uniform])

    def choose(
        self, history: History, candidates: np.ndarray, weight: float, polished: bool
    ) -> np.ndarray:
        surrogate = history.surrogate
        assert surrogate is not None, "a candidate search chooses only with a surrogate"
        observed_best = float(np.min(surrogate.predict(history.select(Status.OK))))
        improvement = st.expected_improvement(
            surrogate.predict(candidates), surrogate.predict_std(candidates), observed_best
        )
        damping = st.pending_damping(candidates, history.select(Status.PENDING), history.sigma)
        chosen: np.ndarray = candidates[int(np.argmax(improvement * damping))]
        return chosen
