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
    :meth:`~demcal.optimizer.responses.ResponsePredictor.expected_improvement`).
    Running points count as if their results were in and equal to the
    prediction (the kriging believer, Ginsbourger et al. 2010): they
    narrow the posteriors around them, and the best predicted objective
    among evaluated and running points is the one to improve on, so
    parallel workers spread out instead of crowding the best region. The
    score is also damped within sigma of running points, for response
    models whose sd does not depend on where the data lie.
    The best point is the evaluated one with the lowest predicted
    objective. Without response models yet, or without an admissible
    candidate, the point is space filling.

    It counts the proposals in a row whose largest expected improvement,
    on the finished results alone, is below ``calm_share`` of the noise
    level (``calm_proposals`` in the strategy state): half of the
    optimizer's rule that the answer is known.
    """

    def propose(self, history: History) -> np.ndarray:
        predictor = history.responses
        finished = history.select(Status.OK)
        if predictor is None or len(finished) == 0:
            return history.space_filling_point()
        predicted = predictor.objective_mean(finished)
        center = finished[int(np.argmin(predicted))]
        s = history.settings
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
        running = history.select(Status.PENDING)
        if len(running):  # calm is judged on results; the choice also on what is running
            believed = float(np.min(predictor.objective_mean(np.vstack([finished, running]))))
            improvement = predictor.expected_improvement(candidates, believed, history.rng, running)
        score = improvement * st.pending_damping(candidates, running, history.sigma)
        if not np.any(score > 0.0):  # no improvement expected anywhere: exploit the prediction
            exploited: np.ndarray = candidates[int(np.argmin(predictor.objective_mean(candidates)))]
            return exploited
        chosen: np.ndarray = candidates[int(np.argmax(score))]
        return chosen
