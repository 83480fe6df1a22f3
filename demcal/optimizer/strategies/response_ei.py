"""Expected improvement of the objective computed from one model per response (Monte Carlo)."""

from __future__ import annotations

import numpy as np

from demcal.results.records import Status

from .. import candidates as st
from .base import History, Strategy


class ResponseEI(Strategy):
    """Expected improvement of the objective computed from one model per response.

    Candidates as DYCORS makes them (perturbations of the best point, with
    the DYCORS step size and coordinate probability) plus as many uniform
    ones; each is scored by the expected improvement of the objective
    applied to the responses' posteriors (Monte Carlo, see
    :meth:`~demcal.optimizer.responses.ResponsePredictor.expected_improvement`), damped
    within sigma of running points. The best point is the evaluated one
    with the lowest predicted objective. Without response models yet, or
    without an admissible candidate, the point is space filling. With models but no
    evaluated point (models taught by neighbouring materials alone), the perturbations are
    of the uniform candidate with the lowest predicted objective.

    It counts the proposals in a row whose largest expected improvement is
    below ``calm_share`` of the noise level (``calm_proposals`` in the
    strategy state): half of the optimizer's rule that the answer is known.
    """

    def propose(self, history: History) -> np.ndarray:
        predictor = history.responses
        finished = history.select(Status.OK)
        if predictor is None:
            return history.space_filling_point()
        s = history.settings
        if len(finished) == 0:  # models taught by neighbouring materials: start at their best
            finished = st.uniform_candidates(s.candidates, history.dimension, history.rng)
        predicted = predictor.objective_mean(finished)
        center = finished[int(np.argmin(predicted))]
        probability = st.perturbation_probability(
            history.dimension, history.evaluated, history.initial_size, s.max_evaluations
        )
        candidates = np.vstack(
            [
                st.perturbation_candidates(
                    center, history.sigma, s.candidates, probability, history.rng
                ),
                st.uniform_candidates(s.candidates, history.dimension, history.rng),
            ]
        )
        keep = history.admissible(candidates)
        if not keep.any():
            return history.space_filling_point()
        candidates = candidates[keep]
        improvement = predictor.expected_improvement(
            candidates, float(np.min(predicted)), history.rng
        )
        calm = float(improvement.max()) < s.calm_share * predictor.noise_level()
        state = history.strategy_state
        state["calm_proposals"] = state.get("calm_proposals", 0) + 1 if calm else 0
        score = improvement * st.pending_damping(
            candidates, history.select(Status.PENDING), history.sigma
        )
        if not np.any(score > 0.0):  # no improvement expected anywhere: exploit the prediction
            exploited: np.ndarray = candidates[int(np.argmin(predictor.objective_mean(candidates)))]
            return exploited
        chosen: np.ndarray = candidates[int(np.argmax(score))]
        return chosen
