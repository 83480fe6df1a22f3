"""What strategies share: the :class:`Strategy` protocol, the :class:`History`, a candidate search.

A strategy chooses the next adaptive point (after the initial design) from a
:class:`History`, a frozen view of everything the optimizer knows, built
afresh for each proposal. Strategies keep no state of their own: what must
persist (random stream, weight cycle, step size, ``strategy_state``) belongs
to the optimizer and is saved in its JSON state. :class:`CandidateSearch` is
the candidate search of Samuelsson (2023), Algorithm 4, that
:class:`~.dycors.Dycors` and :class:`~.kriging_ei.KrigingEI` complete with
their choice of candidate; the maths is in :mod:`..candidates`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.results.records import Status

from .. import candidates as st
from ..responses import ResponsePredictor
from ..settings import OptimizerSettings
from ..surrogates.base import Surrogate


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
    and :attr:`handed_out` place the proposal in the budget; ``reused``: how
    many of the evaluations are points reused from the archive (ok, outside the budget).

    ``responses``: the response models with the objective on top (a
    :class:`~demcal.optimizer.responses.ResponsePredictor`) for the response strategies;
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
    reused: int = 0
    responses: ResponsePredictor | None = None
    response_means: tuple[dict[str, float] | None, ...] = ()
    strategy_state: dict[str, Any] = field(default_factory=dict)

    @property
    def dimension(self) -> int:
        dimension: int = self.points.shape[1]
        return dimension

    @property
    def evaluated(self) -> int:
        """New evaluations told (ok, failed and terminated; the reused points not counted)."""
        return sum(1 for status in self.statuses if status != Status.PENDING) - self.reused

    @property
    def handed_out(self) -> int:
        """New evaluations proposed so far, told or running."""
        return len(self.statuses) - self.reused

    def select(self, *statuses: str) -> np.ndarray:
        """The points with one of ``statuses``."""
        selected: np.ndarray = self.points[
            np.array([status in statuses for status in self.statuses], dtype=bool)
        ]
        return selected

    def admissible(self, candidates: np.ndarray) -> np.ndarray:
        """Which ``candidates`` keep the settings' distance from every point handed out and
        from failed points (boolean mask)."""
        s = self.settings
        keep: np.ndarray = st.admissible(
            candidates,
            self.points,
            s.min_distance,
            self.select(Status.FAILED),
            s.failed_exclusion_radius,
        )
        return keep

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
        keep = history.admissible(candidates)
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
        """One of the admissible ``candidates``; the last is the surrogate minimum when
        ``polished``."""
        raise NotImplementedError
