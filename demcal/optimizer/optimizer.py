"""Asynchronous ask/tell optimizer with JSON state (Samuelsson 2023, Algorithm 5).

The optimizer hands out the initial design first, then one adaptive point
per request, chosen by the strategy named in the settings (`demcal.optimizer.registry`,
`demcal.optimizer.strategies`) from a `History` of the
evaluations. It keeps the bookkeeping and the step size; the strategy only
chooses. Every point handed out, finished, given up or stopped early joins
the distance set A, so running points repel new ones and parallel workers
never get the same point; only finished values enter the surrogate data B
(section 3.6.2: a terminated run updates A but not B). Failed points
additionally exclude a small ball around them.

The best-point rule (`best`), the early-termination reference
(`early_termination`), the confirmation runs (`confirmation`),
the objective's surrogate (`objective_surrogate`) and the JSON state
(`state`) each have their own module of `demcal.optimizer`.

Given the targets (``objective``, a `demcal.optimizer.objective.ResponseObjective`),
the optimizer also keeps each evaluation's responses (`demcal.optimizer.responses`):
replicate values, and what a stopped run completed or estimated. One model
per response then predicts the objective, which picks the best point and
the early-termination threshold, and the response strategies search on it;
a stopped run's responses enter those models, so a region that is stopped
early is not proposed again and again.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from demcal.optimizer.objective import ResponseObjective
from demcal.results.records import ENDED, FINE, Status

from . import candidates as st
from . import state
from .best import best_point
from .bounds import Bounds
from .confirmation import confirmation_summary
from .designs import default_initial_size, initial_design
from .early_termination import (
    EarlyTerminationDecision,
    RunProgress,
    early_termination_decision,
    reference,
)
from .evaluation import BestPoint, Confirmation, Evaluation, ObservedResponse, ReusedPoint
from .levels import LevelOutlook, cheap_is_worth_more
from .objective_surrogate import fit_surrogate, training_data
from .registry import STRATEGIES, strategy_class
from .responses import LevelVerdict, ResponseModels, ResponsePredictor
from .settings import OptimizerSettings
from .stopping import stop_reason
from .strategies.base import History, WeightCycle
from .surrogates.base import Surrogate
from .surrogates.multi_fidelity import MultiFidelityKriging

#: Evaluations at a cheaper level the search may spend per fine evaluation of its budget.
CHEAP_RUNS_PER_FINE = 3


@dataclass(frozen=True)
class Proposal:
    """A point to evaluate: ``id`` (unique, increasing), ``x`` in real units; ``confirms``: the
    id of the point a confirmation run repeats; ``fidelity``: the level it runs at."""

    id: int
    x: list[float]
    in_initial_design: bool
    confirms: int | None = None
    fidelity: str = FINE


def _outcome(
    id: int, value: float | None, status: str, replicates: list[float] | None
) -> dict[str, Any]:
    """The record fields of a told outcome (see `Optimizer.tell`)."""
    if status not in ENDED:
        raise ValueError(f"status: {status!r} is not one of {', '.join(ENDED)}")
    variance, told = None, None
    if status == Status.OK:
        if replicates:
            told = tuple(float(v) for v in replicates)
            if value is None:
                value = float(np.mean(told))
            if len(told) > 1:
                variance = float(np.var(told, ddof=1) / len(told))
        if value is None:
            raise ValueError(f"evaluation {id}: status ok needs a value or replicates")
        value = float(value)
        if not math.isfinite(value) or (variance is not None and not math.isfinite(variance)):
            status, value, variance = Status.FAILED, None, None
    return {
        "status": Status(status),
        "value": value if status == Status.OK else None,
        "variance": variance,
        "replicates": told if status == Status.OK else None,
    }


class Optimizer:
    """Surrogate-based optimizer driven by ask/tell; see the package docstring."""

    def __init__(
        self,
        lower: list[float],
        upper: list[float],
        settings: OptimizerSettings | dict[str, Any] | None = None,
        seed: int = 0,
        initial_points: list[list[float]] | None = None,
        workers: int = 1,
        objective: ResponseObjective | None = None,
        reused: Sequence[ReusedPoint] = (),
    ):
        self.bounds = Bounds.of(lower, upper)
        self.settings = (
            settings
            if isinstance(settings, OptimizerSettings)
            else OptimizerSettings.from_dict(settings)
        )
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers: {workers!r} must be a positive integer")
        self.seed = int(seed)
        self.workers = workers
        self.rng = np.random.default_rng(self.seed)
        dimension = self.bounds.dimension
        per_parameter = STRATEGIES[self.settings.strategy].samples_per_parameter
        self.initial_size = self.settings.initial_size or (
            per_parameter * dimension if per_parameter else default_initial_size(dimension, workers)
        )
        include = None if not initial_points else self.bounds.to_unit(initial_points)
        fine_reused = [p for p in reused if p.fidelity == FINE and p.value is not None]
        covered = self.bounds.to_unit([p.x for p in fine_reused]) if fine_reused else None
        design = initial_design(
            self.settings.initial_design,
            self.initial_size,
            dimension,
            self.rng,
            self.settings.design_tries,
            include,
            covered,
        )
        self.initial_size = len(design)
        self.design_queue: list[list[float]] = design.tolist()
        #: with a cheaper level (``fidelity``): its evaluations, apart from the fine ones in
        #: ``records`` that the search, the answer and the budget count; and the initial design
        #: again at that level, handed out after the fine one
        self.cheap_queue: list[list[float]] = design.tolist() if self.settings.fidelity else []
        taken = [
            Evaluation(
                id,
                tuple(float(v) for v in self.bounds.to_unit([point.x])[0]),
                in_initial_design=False,
                **_outcome(
                    id,
                    point.value,
                    Status.TERMINATED if point.value is None else Status.OK,
                    point.replicates,
                ),
                responses={key: ObservedResponse(tuple(v)) for key, v in point.responses.items()},
                reused_from=point.source,
                fidelity=point.fidelity,
                material=point.material,
            )
            for id, point in enumerate(reused)
        ]
        own = [r for r in taken if not r.material]
        self.records: list[Evaluation] = [r for r in own if r.fidelity == FINE]
        self.cheap_records: list[Evaluation] = [r for r in own if r.fidelity != FINE]
        #: the archive's points of neighbouring materials (``reuse: neighbours``): data of the
        #: response models only, never an answer, a best value or a point of the budget
        self.neighbour_records: list[Evaluation] = [r for r in taken if r.material]
        self.next_id = len(taken)
        self.step = st.StepSize(self.settings.sigma_max)
        self.weight_index = 0
        values = [r.value for r in self.records if r.value is not None]
        self.best_observed: float | None = min(values) if values else None
        self.evaluations_without_improvement = 0
        #: what a strategy must remember between proposals (saved with the state)
        self.strategy_state: dict[str, Any] = {}
        #: why the search for the best point stopped, once it has and the solution set is being
        #: mapped (``map_solutions``); None before
        self.search_ended: str | None = None
        #: evaluations of the solution-set mapping asked for beyond ``map_solutions``
        #: (`explore`)
        self.explore_more = 0
        self.objective = objective
        self._check_objective()
        self._start_models()

    def _check_objective(self) -> None:
        if self.objective is None and STRATEGIES[self.settings.strategy].needs_targets:
            raise ValueError(
                f"optimizer.strategy: {self.settings.strategy} works on the responses and "
                f"needs the targets; give the Optimizer an objective"
            )
        if self.objective is None and self.settings.map_solutions:
            raise ValueError(
                "optimizer.map_solutions: mapping the solution set needs the targets; "
                "give the Optimizer an objective"
            )

    def _start_models(self) -> None:
        """Empty caches of the objective's surrogate and the response models (not saved)."""
        s = self.settings
        self._surrogate: Surrogate | None = None
        self._surrogate_version = -1
        self._response_models = ResponseModels(
            s.response_model, s.duplicate_tolerance, s.kriging_restarts, self.seed
        )
        #: with a cheaper level: the models of both levels' runs (the search's)
        self._level_models = ResponseModels(
            s.response_model, s.duplicate_tolerance, s.kriging_restarts, self.seed
        )

    # ------------------------------------------------------------------ ask
    def ask(self, n: int = 1) -> list[Proposal]:
        """Up to ``n`` new points; fewer once the evaluation budget is handed out.

        Once the search has ended
        ([`stop_reason`][demcal.optimizer.optimizer.Optimizer.stop_reason])
        with ``map_solutions`` left, the points map the solution set instead, after the
        confirmation runs ([`confirm`][demcal.optimizer.optimizer.Optimizer.confirm]): the
        scatter they measure floors the models that choose the mapping points.
        """
        if self.search_ended is not None:
            confirmations = self.confirm(n)
            return confirmations + self._map_solutions(n - len(confirmations))
        proposals: list[Proposal] = []
        while len(proposals) < n:
            fine_room = (
                self.settings.max_evaluations
                - self.completed_evaluations()
                - sum(r.status == Status.PENDING for r in self.records)
            )
            cheap_room = self.cheap_budget - sum(not r.reused_from for r in self.cheap_records)
            if self.design_queue and fine_room > 0:
                proposals.append(self._issue(np.array(self.design_queue.pop(0)), True))
            elif self.cheap_queue and cheap_room > 0:
                unit = np.array(self.cheap_queue.pop(0))
                proposals.append(self._issue(unit, True, fidelity=self.settings.fidelity or FINE))
            elif fine_room > 0:
                point = self._adaptive_point()
                if point is None:  # the strategy waits for running evaluations, or has finished
                    break
                level = self._level_for(point) if cheap_room > 0 else FINE
                proposals.append(self._issue(point, False, fidelity=level))
            else:
                break
        return proposals

    @property
    def cheap_budget(self) -> int:
        """Evaluations at the cheaper level the search may spend in all: CHEAP_RUNS_PER_FINE
        per fine evaluation of the budget (0 without a cheaper level)."""
        return CHEAP_RUNS_PER_FINE * self.settings.max_evaluations if self.settings.fidelity else 0

    def level_cost(self, fidelity: str) -> float:
        """The median CPU seconds of the told evaluations at ``fidelity`` (nan before any)."""
        records = self.records if fidelity == FINE else self.cheap_records
        costs = [r.cpu_s for r in records if r.cpu_s is not None and r.status == Status.OK]
        return float(np.median(costs)) if costs else math.nan

    def cost_ratio(self) -> float:
        """The cheaper level's CPU per evaluation over a fine one's (nan before both ran, or
        without a cheaper level)."""
        level = self.settings.fidelity
        return math.nan if level is None else self.level_cost(level) / self.level_cost(FINE)

    def _level_for(self, unit: np.ndarray) -> str:
        """The level the next evaluation at ``unit`` runs at: the cheaper one when it is worth
        more per CPU second than a fine run (:func:`.levels.cheap_is_worth_more`) for the
        responses whose multi-fidelity model says the level pays; fine otherwise."""
        fidelity = self.settings.fidelity
        predictor = self.response_predictor(levels=True)
        if fidelity is None or predictor is None:
            return FINE
        fine: list[LevelOutlook] = []
        cheap: list[LevelOutlook | None] = []
        for model in predictor.models.values():
            if isinstance(model, MultiFidelityKriging):
                at_fine, at_cheap = model.outlooks(unit)
                fine.append(at_fine)
                cheap.append(at_cheap)
            else:
                sd = float(model.predict_std(np.atleast_2d(unit))[0])
                fine.append(LevelOutlook(1.0, sd, model.noise_sd))
                cheap.append(None)
        return fidelity if cheap_is_worth_more(fine, cheap, self.cost_ratio()) else FINE

    def _map_solutions(self, n: int) -> list[Proposal]:
        """Up to ``n`` points of the solution-set mapping, within ``map_solutions``."""
        room = self.mapping_budget - sum(r.maps_solutions for r in self.records)
        proposals = []
        for _ in range(max(min(n, room), 0)):
            weights = WeightCycle(self.settings.weights, self.weight_index)
            unit = strategy_class("solution_map")().propose(self._history(weights, mapping=True))
            if unit is None:
                break
            proposals.append(self._issue(unit, in_design=False, maps_solutions=True))
        return proposals

    def _issue(
        self,
        unit: np.ndarray,
        in_design: bool,
        confirms: int | None = None,
        by_hand: bool = False,
        maps_solutions: bool = False,
        fidelity: str = FINE,
    ) -> Proposal:
        record = Evaluation(
            self.next_id,
            tuple(float(v) for v in unit),
            in_design,
            confirms=confirms,
            by_hand=by_hand,
            maps_solutions=maps_solutions,
            fidelity=fidelity,
        )
        (self.records if fidelity == FINE else self.cheap_records).append(record)
        self.next_id += 1
        x = self.bounds.from_unit(unit)[0].tolist()
        return Proposal(record.id, x, in_design, confirms, fidelity)

    def add_point(self, x: list[float]) -> Proposal:
        """A point given by hand (a colleague's, a previous best): pending, evaluated like any
        other.

        Raises ValueError if it lies outside the bounds. It counts towards the
        budget and, once told, joins every model's data.
        """
        return self._issue(self.bounds.to_unit([x])[0], in_design=False, by_hand=True)

    def _adaptive_point(self) -> np.ndarray | None:
        """The point the configured strategy chooses from the current history (None: none now)."""
        weights = WeightCycle(self.settings.weights, self.weight_index)
        point = strategy_class(self.settings.strategy)().propose(self._history(weights))
        self.weight_index = weights.index
        return point

    def _history(self, weights: WeightCycle, mapping: bool = False) -> History:
        """The frozen view of the evaluations that a strategy receives (``mapping``: for the
        solution-set mapping, which needs the response models whatever the strategy)."""
        # a cheap run still running keeps new points away from it, as a fine one does
        running_cheap = [r for r in self.cheap_records if r.status == Status.PENDING]
        records, dimension = [*self.records, *running_cheap], self.bounds.dimension
        return History(
            ids=tuple(r.id for r in records),
            points=np.array([r.x for r in records], float).reshape(len(records), dimension),
            statuses=tuple(r.status for r in records),
            values=np.array([r.value if r.finished else np.nan for r in records], float),
            variances=np.array(
                [(r.variance or 0.0) if r.finished else np.nan for r in records], float
            ),
            in_initial_design=np.array([r.in_initial_design for r in records], bool),
            surrogate=self._fitted_surrogate(),
            sigma=self.step.sigma,
            rng=self.rng,
            weights=weights,
            settings=self.settings,
            initial_size=self.initial_size,
            reused=self.reused_points,
            responses=self.response_predictor(levels=True)
            if mapping or STRATEGIES[self.settings.strategy].needs_targets
            else None,
            response_means=tuple(
                {key: entry.mean for key, entry in r.responses.items() if entry.final}
                if r.finished and r.responses
                else None
                for r in records
            ),
            strategy_state=self.strategy_state,
        )

    # ----------------------------------------------------------------- tell
    def tell(
        self,
        id: int,
        value: float | None = None,
        status: str = Status.OK,
        replicates: list[float] | None = None,
        responses: dict[str, list[float]] | None = None,
        partial: dict[str, dict[str, Any]] | None = None,
        cpu_s: float | None = None,
    ) -> None:
        """Report the outcome of proposal ``id``.

        ``status``: "ok" with ``value`` and/or ``replicates`` (the value
        defaults to their mean; their spread becomes the value's variance);
        "failed" (the point and a small ball around it are never proposed
        again); "terminated" (stopped early: kept in the distance set only).
        A non-finite value is recorded as failed.

        ``responses`` ("ok"): each response's replicate values, keyed
        ``scene.response``; with an objective and no value given, the value
        and its replicates follow from them. ``partial`` ("terminated"): what
        the stopped run reported, ``{key: {"values": [...], "final": bool}}``
        (final: the response was complete; else an early estimate). ``cpu_s``: what its
        simulations cost (the cost of each level, for the choice of level).
        """
        record = self._record(id)
        if record.status != Status.PENDING:
            raise ValueError(f"evaluation {id} was already told ({record.status})")
        if (
            status == Status.OK
            and responses
            and value is None
            and replicates is None
            and self.objective is not None
        ):
            value, replicates = self._objective_of(responses)
        observed = (
            partial if status == Status.TERMINATED else (responses if status == Status.OK else None)
        )
        record = self._replace(
            id,
            **_outcome(id, value, status, replicates),
            responses={key: ObservedResponse.of(entry) for key, entry in (observed or {}).items()},
            cpu_s=cpu_s,
        )
        if record.fidelity == FINE:  # a cheaper level's value is not the objective's
            self._update_progress(record)

    def _objective_of(self, responses: dict[str, list[float]]) -> tuple[float, list[float] | None]:
        """The objective of the replicates' responses, and per replicate when the counts agree
        (the study's one computation, `demcal.optimizer.objective.ResponseObjective`)."""
        objective = self.objective
        assert objective is not None, "tell scores responses only with an objective"
        targeted = {key: responses[key] for key in objective.keys}
        try:
            value = objective.of_replicates(targeted)
        except ValueError:  # not finite: recorded as failed
            value = math.nan
        return value, objective.per_replicate(targeted) or None

    def reopen(self, id: int) -> None:
        """Make a told evaluation pending again, to be rerun and told anew (rerun on request).

        Its old outcome leaves the surrogate data; the step-size history is kept.
        """
        if self._record(id).status == Status.PENDING:
            raise ValueError(f"evaluation {id} is still pending")
        self._replace(
            id, status=Status.PENDING, value=None, variance=None, replicates=None, responses={}
        )
        self._surrogate_version = -1

    def rescore(self, outcomes: dict[int, tuple[str, float | None, list[float] | None]]) -> None:
        """Replace told outcomes by re-scored ones: id -> (status, value, replicates).

        For an objective recomputed from stored responses (new targets or
        weights). The best value follows the new values; the step-size
        history is kept, the surrogate is refitted.
        """
        for id, (status, value, replicates) in outcomes.items():
            if self._record(id).status == Status.PENDING:
                raise ValueError(f"evaluation {id} is pending, it cannot be re-scored")
            self._replace(id, **_outcome(id, value, status, replicates))
        values = [r.value for r in self.records if r.value is not None]
        self.best_observed = min(values) if values else None
        self._surrogate_version = -1
        # the search is judged anew on the new objective
        self.strategy_state.pop("calm_proposals", None)
        self.search_ended = None

    def _update_progress(self, record: Evaluation) -> None:
        if record.status == Status.FAILED:
            self.evaluations_without_improvement += 1
            return
        value = record.value  # None when stopped early
        improved = value is not None and st.is_improvement(value, self.best_observed)
        if not record.in_initial_design:
            s = self.settings
            self.step.record(
                improved,
                s.sigma_min,
                s.sigma_max,
                s.success_tolerance,
                s.failures_to_halve(self.bounds.dimension),
            )
        if value is not None and (self.best_observed is None or value < self.best_observed):
            self.best_observed = value
        self.evaluations_without_improvement = (
            0 if improved else self.evaluations_without_improvement + 1
        )

    # ------------------------------------------------------------ queries
    def completed_evaluations(self) -> int:
        """Evaluations told so far (ok, failed and terminated); reused points are not among
        them: the budget counts new simulations."""
        return sum(1 for r in self.records if r.status != Status.PENDING and not r.reused_from)

    def status_counts(self) -> dict[str, int]:
        """How many evaluations are ok, failed, terminated and pending (only those that occur;
        reused points not counted)."""
        return dict(Counter(str(r.status) for r in self.records if not r.reused_from))

    @property
    def reused_points(self) -> int:
        """Points taken from the archive (``reused`` when the optimizer was made)."""
        return sum(1 for r in self.records if r.reused_from)

    def pending(self) -> list[int]:
        """Ids handed out and not yet told, at every level."""
        return [r.id for r in [*self.records, *self.cheap_records] if r.status == Status.PENDING]

    def level_verdicts(self) -> dict[str, LevelVerdict]:
        """Per targeted response, whether the cheaper level pays, as last judged (none before
        the level has data)."""
        return dict(self._level_models.verdicts)

    def best(self) -> BestPoint | None:
        """The best evaluated point, and how it was chosen (``chosen_by``); see
        `demcal.optimizer.best`.

        Once the best point has been confirmed
        ([`confirm`][demcal.optimizer.optimizer.Optimizer.confirm]), it stays the answer. None
        before any value.
        """
        return best_point(
            self.records, self.bounds, self.response_predictor, self._fitted_surrogate
        )

    def response_predictor(
        self, objective: ResponseObjective | None = None, levels: bool = False
    ) -> ResponsePredictor | None:
        """The models of the targeted responses with ``objective`` (default: the optimizer's) on
        top: of the fine runs alone, which the answer, the stopping rules and every "within
        spread" claim rest on; with ``levels``, of the cheaper level's runs too where it pays
        (multi-fidelity models), which the search and the solution set use.

        Inputs in the unit box. None without an objective or while some
        targeted response has fewer than d + 2 fine observations.
        """
        objective = objective or self.objective
        if objective is None:
            return None
        dimension = self.bounds.dimension
        if levels and self.settings.fidelity:
            models = self._level_models.fit(
                self.records, objective.keys, dimension, self.cheap_records, self.cost_ratio()
            )
        else:
            models = self._response_models.fit(
                self.records, objective.keys, dimension, neighbours=self.neighbour_records
            )
        return None if models is None else ResponsePredictor(models, objective)

    def stop_reason(self, elapsed_seconds: float) -> str | None:
        """Why the run should stop (budget, wall clock, target, stagnation, collapse) or None.

        With ``map_solutions``, the first stop of the search starts the
        mapping of the solution set instead; the run stops once those
        evaluations are told (or on the wall clock).
        """
        reason = self._search_stop_reason(elapsed_seconds)
        wanted = self.mapping_budget
        if reason is None or not wanted or reason.startswith("wall-clock"):
            return reason
        self.search_ended = self.search_ended or reason
        mapped = sum(r.maps_solutions and r.status != Status.PENDING for r in self.records)
        if mapped < wanted:
            return None
        return f"{self.search_ended}; then {mapped} evaluations mapped the solution set"

    @property
    def mapping_budget(self) -> int:
        """Evaluations that map the solution set in all: ``map_solutions`` and those
        [`explore`][demcal.optimizer.optimizer.Optimizer.explore] added."""
        return self.settings.map_solutions + self.explore_more

    def explore(self, n: int) -> None:
        """Map the solution set with ``n`` more evaluations, now (ends the search if it had not
        ended). ValueError without the targets."""
        if self.objective is None:
            raise ValueError("mapping the solution set needs the targets as response models")
        self.explore_more += n
        self.search_ended = self.search_ended or "exploring the solution set was asked for"

    def _search_stop_reason(self, elapsed_seconds: float) -> str | None:
        """Why the search for the best point should stop, or None."""
        if self.search_ended is not None:
            return self.search_ended
        s = self.settings
        strategy_reason: str | None = self.strategy_state.get("stop_reason")
        if strategy_reason:
            return strategy_reason
        best = self.best()
        if best is not None and self._answer_known(best):
            return (
                "answer known: the best point's predicted responses meet every target within "
                f"its spread, and the expected improvement stayed below {s.calm_share:.0%} of "
                f"the noise level for {s.calm_proposals} proposals"
            )
        return stop_reason(
            self.completed_evaluations(),
            s.max_evaluations,
            elapsed_seconds,
            s.max_seconds,
            None if best is None else best.predicted,
            s.target_objective,
            self.evaluations_without_improvement,
            s.no_improvement_evaluations,
            self.step.collapsed and s.stop_on_step_collapse and STRATEGIES[s.strategy].step_size,
        )

    def _answer_known(self, best: BestPoint) -> bool:
        """The rule ``stop_when_known``: the strategy counted ``calm_proposals`` proposals in a
        row of negligible expected improvement, and the best point meets the targets."""
        s = self.settings
        if not s.stop_when_known or self.strategy_state.get("calm_proposals", 0) < s.calm_proposals:
            return False
        predictor = self.response_predictor()
        return predictor is not None and predictor.meets_targets(self.bounds.to_unit([best.x])[0])

    def early_termination(
        self, id: int, partial_estimate: float, run: RunProgress | None = None
    ) -> EarlyTerminationDecision:
        """Apply `early_termination_decision` to running evaluation ``id``; ``run``: where it
        stands (share done, the estimate's heading), for the ``weighed`` rule."""
        record = self._record(id)
        et = self.settings.early_termination
        adaptive_budget = max(self.settings.max_evaluations - self.initial_size, 1)
        progress = (self.completed_evaluations() - self.initial_size) / adaptive_budget
        return early_termination_decision(
            reference(
                self.best(),
                self.best_observed,
                self.records,
                self.response_predictor,
                self.objective,
                run,
            ),
            partial_estimate,
            progress,
            in_initial_design=record.in_initial_design,
            enabled=self._may_stop(record),
            thresholds=et.thresholds,
            progress_boundaries=et.progress_boundaries,
            run=run,
            rule=et.rule,
            last_stretch=et.last_stretch,
        )

    def _may_stop(self, record: Evaluation) -> bool:
        """Whether early termination applies to an evaluation of this kind (the initial design
        aside): on, with a strategy that stops runs, and not a confirmation or mapping run."""
        return (
            self.settings.early_termination.enabled
            and STRATEGIES[self.settings.strategy].stops_early
            and record.confirms is None
            and not record.maps_solutions
            and record.fidelity == FINE
        )

    def can_stop_early(self, id: int) -> bool:
        """Whether early termination may stop evaluation ``id`` (then its first simulations
        are worth running first: a staged study stages it)."""
        record = self._record(id)
        return self._may_stop(record) and not record.in_initial_design

    # ------------------------------------------------------- confirmation
    def confirm(self, n: int | None = None) -> list[Proposal]:
        """Proposals that simulate the best point again, ``confirm_replicates`` times per run in
        all (``n``: at most this many now).

        For after the search has stopped. The confirmations are ordinary
        evaluations (they join the response data) marked with the id they
        confirm; early termination never stops them. [] when none are
        wanted, all were made already or there is no best point.
        """
        best = self.best()
        due = self.settings.confirm_replicates - sum(r.confirms is not None for r in self.records)
        if best is None or due <= 0:
            return []
        unit = np.array(self._record(best.id).x)
        count = due if n is None else min(due, n)
        return [self._issue(unit, in_design=False, confirms=best.id) for _ in range(count)]

    def confirmation(self) -> Confirmation | None:
        """The confirmation runs so far (see
        `demcal.optimizer.confirmation.confirmation_summary`)."""
        return confirmation_summary(self.records, self.objective.keys if self.objective else [])

    def _index(self, id: int) -> tuple[list[Evaluation], int]:
        """The list that holds evaluation ``id`` (fine or cheaper level) and its place there."""
        for records in (self.records, self.cheap_records):
            for index, record in enumerate(records):
                if record.id == id:
                    return records, index
        raise ValueError(f"unknown evaluation id {id!r}")

    def _record(self, id: int) -> Evaluation:
        records, index = self._index(id)
        return records[index]

    def _replace(self, id: int, **changes: Any) -> Evaluation:
        """Replace evaluation ``id``'s record by a copy with ``changes``; returns the new one."""
        records, index = self._index(id)
        records[index] = replace(records[index], **changes)
        return records[index]

    def _fitted_surrogate(self) -> Surrogate | None:
        """The surrogate of the objective (`demcal.optimizer.objective_surrogate`), refitted
        only when its data changed."""
        data = training_data(self.records, self.bounds.dimension, self.objective)
        if data is None:
            return None
        if self._surrogate_version != len(data):
            self._surrogate = fit_surrogate(self.settings, self.seed, data)
            self._surrogate_version = len(data)
        return self._surrogate

    # -------------------------------------------------------------- state
    def to_json(self) -> str:
        """The whole state as JSON (`demcal.optimizer.state`);
        [`from_json`][demcal.optimizer.optimizer.Optimizer.from_json] resumes to the same next
        proposal."""
        return state.encode(self)

    @classmethod
    def from_json(cls, text: str, objective: ResponseObjective | None = None) -> Optimizer:
        """The optimizer saved in ``text``, scoring responses with ``objective`` (the state names
        the objective's version, not its targets: ValueError if it had one and none is given)."""
        optimizer = cls.__new__(cls)
        vars(optimizer).update(state.decode(text, objective))
        optimizer._start_models()
        return optimizer
