"""demcal's optimizer: chooses where to simulate next. Pure Python, no files, no processes.

Methods: Samuelsson (2023) — symmetric Latin hypercube start, cubic RBF
surrogate with linear tail, MSRS/DYCORS candidate search, asynchronous
workers, early termination (Algorithms 3–5, Table 4.2); Rackl & Hanley
(2017) — universal Kriging with Matérn kernel, linear drift and nugget, one
model per response, and their Levenberg–Marquardt procedure.

Public API (the first import line is what the daemon uses; the second
is for adding a strategy, see below):

    from demcal.optimizer import (
        Optimizer, OptimizerSettings, Proposal, Bounds, early_termination_decision,
        Strategy, History, register_strategy,
    )

    opt = Optimizer(lower, upper, settings=None, seed=0, initial_points=None, workers=1,
                    objective=None, reused=())
        # lower/upper: list[float] in real units; settings: OptimizerSettings,
        # or the plain dict of the config section ``optimizer:`` (unknown keys
        # and out-of-range values raise ValueError naming key, value, range);
        # objective: a demcal.optimizer.objective.ResponseObjective (the targets),
        # needed by the strategies that model each response (response_ei,
        # rackl_hanley) and used by all for the best point when given;
        # reused: ReusedPoint (.evaluation) of other studies, ok records from
        # the start, outside the budget; the initial design shrinks by them
    opt.ask(n=1) -> list[Proposal]
        # Proposal.id: unique increasing int; Proposal.x: list[float] (real
        # units); Proposal.in_initial_design: bool. May be called while other
        # points are pending; they repel new points. Returns fewer than n once
        # the evaluation budget is handed out, or when the strategy waits.
    opt.add_point(x) -> Proposal     # a point given by hand, pending like any other
    opt.tell(id, value=None, status="ok", replicates=None, responses=None, partial=None)
        # status "ok" (value and/or replicates, or responses: {key: [replicate
        # values]} from which the objective gives the value), "failed"
        # (excluded, never proposed again nearby; retries are the caller's
        # business) or "terminated" (early-stopped: distance set only, not
        # surrogate data; partial: {key: {"values": [...], "final": bool}},
        # what the stopped run measured, which the response models learn from)
    opt.reopen(id)                       # a told evaluation is pending again
    opt.rescore({id: (status, value, replicates)})  # replace told outcomes
    opt.pending() -> list[int];  opt.completed_evaluations() -> int
    opt.status_counts() -> {status: count}
    opt.records  # list of Evaluation (.evaluation): id, x (unit box), status,
                 # value, variance, replicates, in_initial_design, responses
                 # ({key: ObservedResponse}), by_hand (add_point), confirms
                 # (the id a confirmation repeats), reused_from (a reused
                 # point's study/evaluation; opt.reused_points counts them)
    opt.settings;  opt.objective;  opt.bounds (Bounds)
    opt.best_observed  # lowest ok value so far, or None
    opt.best() -> BestPoint | None  # id, x, value, predicted, chosen_by,
                                    # on_bounds, responses (response models)
        # with response models: the evaluated point of lowest predicted
        # objective; else the one whose larger of observed and predicted
        # value is lowest; a confirmed point stays the answer
    opt.response_predictor(objective=None, levels=False) -> ResponsePredictor | None
        # one model per targeted response, the objective on top
    opt.early_termination(id, partial_estimate, run=None) -> EarlyTerminationDecision
        # run: RunProgress(done, heading, estimated, provisional), where it stands
    opt.stop_reason(elapsed_seconds) -> str | None
    opt.confirm() -> list[Proposal]      # after the stop: the best point again
    opt.confirmation() -> Confirmation | None  # what the confirmation runs found
    opt.to_json() -> str;  Optimizer.from_json(s) -> Optimizer
        # same state, same next proposal

    early_termination_decision(best_value, partial_estimate, progress,
                               in_initial_design=False, enabled=True,
                               thresholds=(10, 5, 2.5),
                               progress_boundaries=(0.5, 0.75),
                               run=None, rule="weighed", last_stretch=0.9)
        # .stop is True when partial_estimate > c * best_value (thesis eq. 3.4);
        # weighed: > c * best_value / (1 - run.done), never in the last stretch
    estimate_heading(history) -> float | None  # trend of (done, estimate) at done = 1

Adding a strategy: subclass ``Strategy`` and implement
``propose(history: History) -> numpy.ndarray | None`` (the next point in
the unit box, or None for none now), or subclass
``strategies.base.CandidateSearch`` and implement ``choose`` to reuse the
candidate search of dycors and kriging_ei; then
``register_strategy(name, cls, **metadata)`` with the fields of
``registry.StrategyEntry`` (default surrogate, usable surrogates, initial
design size, whether it needs the targets, ...), or add an entry to
``registry.STRATEGIES``. ``optimizer.strategy: name`` is then valid in the
settings and used by the optimizer, with no other change. ``History`` is a
frozen view of the evaluations (unit points, statuses, values, variances,
the fitted surrogate, the response models, step size, rng, weight cycle,
settings, budget position, and ``strategy_state``, the strategy's saved
memory). A strategy is created afresh for each proposal and keeps no state
of its own: all that must survive a restart is in the optimizer's JSON
state. Surrogates, response models and initial designs are registered the
same way (``registry.SURROGATES``, ``RESPONSE_MODELS``, ``DESIGNS``).

Modules: optimizer (ask/tell and bookkeeping), best (the best-point rule),
confirmation, objective_surrogate (the objective's surrogate: its data and
fit), state (the JSON state), registry (the plug-ins by name, imported on
first use; the lists the settings validate), strategies/ (one module per
strategy, the ``Strategy`` protocol and ``History`` in strategies.base),
candidates (the pure maths: candidates, scores, expected improvement, step
size), surrogates/ (one module per model behind one fit/predict
interface), responses (per-response data and models, the objective on
top), designs (initial designs), early_termination (the rule and its
reference value), stopping, settings, bounds.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Names resolve on first use (PEP 562): the workflow's jobs validate the
# config with OptimizerSettings alone and skip the SciPy/SMT imports that
# the strategies and surrogates need.
_EXPORTS = {
    "Bounds": "bounds",
    "EarlyTerminationDecision": "early_termination",
    "EarlyTerminationSettings": "settings",
    "History": "strategies.base",
    "Optimizer": "optimizer",
    "OptimizerSettings": "settings",
    "Proposal": "optimizer",
    "RunProgress": "early_termination",
    "Strategy": "strategies.base",
    "early_termination_decision": "early_termination",
    "estimate_heading": "early_termination",
    "register_strategy": "registry",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:  # the names as mypy sees them; at run time __getattr__ imports them
    from .bounds import Bounds as Bounds
    from .early_termination import EarlyTerminationDecision as EarlyTerminationDecision
    from .early_termination import RunProgress as RunProgress
    from .early_termination import early_termination_decision as early_termination_decision
    from .early_termination import estimate_heading as estimate_heading
    from .optimizer import Optimizer as Optimizer
    from .optimizer import Proposal as Proposal
    from .registry import register_strategy as register_strategy
    from .settings import EarlyTerminationSettings as EarlyTerminationSettings
    from .settings import OptimizerSettings as OptimizerSettings
    from .strategies.base import History as History
    from .strategies.base import Strategy as Strategy


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
