"""Search strategies: the protocol, the data each one receives, and the built-in two.

A strategy chooses the next adaptive point (after the initial design) from a
:class:`History`, a frozen view of everything the optimizer knows, built
afresh for each proposal. Strategies keep no state of their own: what must
persist (random stream, weight cycle, step size) belongs to the optimizer
and is saved in its JSON state. The math is in :mod:`.strategies`.

* :class:`Dycors` — MSRS/DYCORS (Samuelsson 2023, Algorithm 4): perturbation
  candidates scored by weighted surrogate value and distance.
* :class:`KrigingEI` — perturbation and uniform candidates scored by expected
  improvement, damped near running points (Samuelsson 2023, sec. 2.2.2.3).

Both run the same candidate search (:class:`CandidateSearch`) and differ in
the candidates they add and in how they pick one. Adding a strategy: subclass
:class:`Strategy` (or :class:`CandidateSearch`), then register it by name in
:mod:`.registry`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from demcal.results.records import Status

from . import candidates as st
from .responses import ResponsePredictor
from .settings import OptimizerSettings
from .surrogates import Surrogate


class WeightCycle:
    """The merit weights used in turn (Algorithm 4); ``index`` counts the weights drawn so far."""

    def __init__(self, weights: tuple[float, ...], index: int = 0):
        self.weights = weights
        self.index = index

    def next(self) -> float:
        weight = self.weights[self.index % len(self.weights)]
        self.index += 1
        return weight


@dataclass(frozen=True, eq=False)
class History:
    """What a strategy knows when it chooses a point; all points in the unit box.

    Per evaluation handed out, in id order: ``ids``, ``points`` (n x d),
    ``statuses`` ("pending", "ok", "failed", "terminated"), ``values`` (NaN
    unless ok), ``variances`` (of each value, from replicates; 0 without,
    NaN unless ok) and ``in_initial_design``.

    ``surrogate``: fitted on the ok values, None while there are fewer than
    d + 2. ``sigma``: the current step size. ``rng`` and ``weights`` are the
    optimizer's own streams: drawing from them advances its saved state.
    ``initial_size`` and ``settings.max_evaluations`` with :attr:`evaluated`
    and :attr:`handed_out` place the proposal in the budget.

    ``responses``: the response models with the objective on top (a
    :class:`~.responses.ResponsePredictor`) for the response strategies;
    None for the others and while some response has too few observations.
    ``response_means``: per evaluation, its replicate-mean responses where it
    finished ok (else None). ``strategy_state``: the optimizer's mutable,
    saved record of what a strategy must remember between proposals (e.g.
    the Levenberg–Marquardt iterate); set ``stop_reason`` in it to end the
    calibration.
    """

    ids: tuple[int, ...]
    points: np.ndarray
    statuses: tuple[str, ...]
    values: np.ndarray
    variances: np.ndarray
    in_initial_design: np.ndarray
    surrogate: Surrogate | None
    sigma: float
    rng: np.random.Generator
    weights: WeightCycle
    settings: OptimizerSettings
    initial_size: int
    responses: ResponsePredictor | None = None
    response_means: tuple[dict | None, ...] = ()
    strategy_state: dict = field(default_factory=dict)

    @property
    def dimension(self) -> int:
        return self.points.shape[1]

    @property
    def evaluated(self) -> int:
        """Evaluations told (ok, failed and terminated)."""
        return sum(1 for status in self.statuses if status != Status.PENDING)

    @property
    def handed_out(self) -> int:
        """Evaluations proposed so far, told or running."""
        return len(self.statuses)

    def select(self, *statuses: str) -> np.ndarray:
        """The points with one of ``statuses``."""
        return self.points[np.array([status in statuses for status in self.statuses], dtype=bool)]

    def space_filling_point(self) -> np.ndarray:
        """The point farthest from all others, clear of failed points (no surrogate needed)."""
        s = self.settings
        return st.space_filling_point(
            self.points,
            self.select(Status.FAILED),
            s.failed_exclusion_radius,
            s.candidates,
            self.rng,
        )


class Strategy:
    """The protocol: :meth:`propose` returns the next point in the unit box.

    It may return None: no point now (it waits for running evaluations) or
    no point any more (it has set ``history.strategy_state["stop_reason"]``).
    """

    def propose(self, history: History) -> np.ndarray | None:
        raise NotImplementedError


class CandidateSearch(Strategy):
    """Candidates around the best point, filtered, then one chosen (Algorithm 4).

    Candidates must keep ``min_distance`` from all points handed out (the
    distance set A: running, finished, failed and terminated) and
    ``failed_exclusion_radius`` from failed points. Without a surrogate, or
    when no candidate is admissible, the point is space filling.
    Subclasses may add :meth:`candidates` and must implement :meth:`choose`.
    """

    def propose(self, history: History) -> np.ndarray:
        s, surrogate = history.settings, history.surrogate
        if surrogate is None:
            return history.space_filling_point()
        finished = history.select(Status.OK)
        center = finished[int(np.argmin(surrogate.predict(finished)))]
        candidates = self.candidates(history, center)
        if s.polish_candidate:
            candidates = np.vstack(
                [candidates, st.surrogate_minimum(surrogate, center, 2 * history.sigma)]
            )
        keep = st.admissible(
            candidates,
            history.points,
            s.min_distance,
            history.select(Status.FAILED),
            s.failed_exclusion_radius,
        )
        if not keep.any():
            return history.space_filling_point()
        weight = (
            history.weights.next()
        )  # drawn by every strategy here, used or not: same saved states
        return self.choose(
            history, candidates[keep], weight, polished=s.polish_candidate and bool(keep[-1])
        )

    def candidates(self, history: History, center: np.ndarray) -> np.ndarray:
        """DYCORS perturbations of ``center`` (Samuelsson 2023, sec. 3.5.1.2)."""
        s = history.settings
        probability = st.perturbation_probability(
            history.dimension, history.evaluated, history.initial_size, s.max_evaluations
        )
        return st.perturbation_candidates(
            center, history.sigma, s.candidates, probability, history.rng
        )

    def choose(
        self, history: History, candidates: np.ndarray, weight: float, polished: bool
    ) -> np.ndarray:
        """One of the admissible ``candidates``; the last is the surrogate minimum when ``polished``."""
        raise NotImplementedError


class Dycors(CandidateSearch):
    """MSRS/DYCORS: lowest weighted score of surrogate value and distance (Algorithm 4, steps c–e).

    With ``polish_candidate``, the surrogate minimum is taken as it is at
    the most exploitative weight and in the last ``final_exploitation``
    share of the budget.
    """

    def choose(
        self, history: History, candidates: np.ndarray, weight: float, polished: bool
    ) -> np.ndarray:
        s = history.settings
        final = history.handed_out >= s.max_evaluations * (1.0 - s.final_exploitation)
        if polished and (weight == max(s.weights) or final):
            return candidates[-1]
        scores = st.weighted_scores(
            history.surrogate.predict(candidates),
            st.nearest_distances(candidates, history.points),
            weight,
        )
        return candidates[int(np.argmin(scores))]


class KrigingEI(CandidateSearch):
    """Highest expected improvement over the best prediction, damped within sigma of running points."""

    def candidates(self, history: History, center: np.ndarray) -> np.ndarray:
        perturbed = super().candidates(history, center)
        uniform = st.uniform_candidates(history.settings.candidates, history.dimension, history.rng)
        return np.vstack([perturbed, uniform])

    def choose(
        self, history: History, candidates: np.ndarray, weight: float, polished: bool
    ) -> np.ndarray:
        surrogate = history.surrogate
        observed_best = float(np.min(surrogate.predict(history.select(Status.OK))))
        improvement = st.expected_improvement(
            surrogate.predict(candidates), surrogate.predict_std(candidates), observed_best
        )
        damping = st.pending_damping(candidates, history.select(Status.PENDING), history.sigma)
        return candidates[int(np.argmax(improvement * damping))]


class ResponseEI(Strategy):
    """Expected improvement of the objective computed from one model per response.

    Candidates as DYCORS makes them (perturbations of the best point, with
    the DYCORS step size and coordinate probability) plus as many uniform
    ones; each is scored by the expected improvement of the objective
    applied to the responses' posteriors (Monte Carlo, see
    :meth:`~.responses.ResponsePredictor.expected_improvement`), damped
    within sigma of running points. The best point is the evaluated one
    with the lowest predicted objective. Without response models yet, or
    without an admissible candidate, the point is space filling.
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
        keep = st.admissible(
            candidates,
            history.points,
            s.min_distance,
            history.select(Status.FAILED),
            s.failed_exclusion_radius,
        )
        if not keep.any():
            return history.space_filling_point()
        candidates = candidates[keep]
        improvement = predictor.expected_improvement(
            candidates, float(np.min(predicted)), history.rng
        )
        score = improvement * st.pending_damping(
            candidates, history.select(Status.PENDING), history.sigma
        )
        if not np.any(score > 0.0):  # no improvement expected anywhere: exploit the prediction
            return candidates[int(np.argmin(predictor.objective_mean(candidates)))]
        return candidates[int(np.argmax(score))]
