"""demcal's optimizer: chooses where to simulate next. Pure Python, no files, no processes.

Methods: Samuelsson (2023) — symmetric Latin hypercube start, cubic RBF
surrogate with linear tail, MSRS/DYCORS candidate search, asynchronous
workers, early termination (Algorithms 3–5, Table 4.2); Rackl & Hanley
(2017) — universal Kriging with Matérn kernel, linear drift and nugget.

Public API (the first import line is what the daemon uses; the second
is for adding a strategy, see below)::

    from demcal.optimizer import (
        Optimizer, OptimizerSettings, Proposal, Bounds, early_termination_decision,
        Strategy, History, register_strategy,
    )

    opt = Optimizer(lower, upper, settings, seed, initial_points=None, workers=1)
        # lower/upper: list[float] in real units; settings: OptimizerSettings,
        # or the plain dict of the config section ``optimizer:`` (unknown keys
        # and out-of-range values raise ValueError naming key, value, range)
    opt.ask(n=1) -> list[Proposal]
        # Proposal.id: unique increasing int; Proposal.x: list[float] (real
        # units); Proposal.in_initial_design: bool. May be called while other
        # points are pending; they repel new points. Returns fewer than n once
        # the evaluation budget is handed out.
    opt.tell(id, value=None, status="ok", replicates=None)
        # status "ok" (value and/or replicates), "failed" (excluded, never
        # proposed again nearby; retries are the caller's business) or
        # "terminated" (early-stopped: distance set only, not surrogate data)
    opt.reopen(id)                       # a told evaluation is pending again
    opt.rescore({id: (status, value, replicates)})  # replace told outcomes
    opt.pending() -> list[int];  opt.completed_evaluations() -> int
    opt.records  # list of dicts: id, x (unit box), status, value, variance,
                 # replicates, in_initial_design
    opt.settings;  opt.best_observed  # lowest ok value so far, or None
    opt.best() -> {"x", "value", "predicted", "id"} | None
        # the evaluated point whose larger of observed and predicted value
        # is lowest
    opt.early_termination(id, partial_estimate) -> EarlyTerminationDecision
    opt.stop_reason(elapsed_seconds) -> str | None
    opt.to_json() -> str;  Optimizer.from_json(s) -> Optimizer
        # same state, same next proposal

    early_termination_decision(best_value, partial_estimate, progress,
                               in_initial_design=False, enabled=True,
                               thresholds=(10, 5, 2.5),
                               progress_boundaries=(0.5, 0.75))
        # .stop is True when partial_estimate > c * best_value (thesis eq. 3.4)

Adding a strategy: subclass ``Strategy`` and implement
``propose(history: History) -> numpy.ndarray`` (the next point in the unit
box), or subclass ``search.CandidateSearch`` and implement ``choose`` to
reuse the candidate search of the built-in two; then
``register_strategy(name, cls, surrogate="cubic_rbf", surrogates=None)``
(or add a line to ``registry.STRATEGIES``). ``optimizer.strategy: name``
is then valid in the settings and used by the optimizer, with no other
change. ``History`` is a frozen view of the evaluations (unit points,
statuses, values, variances, the fitted surrogate, step size, rng, weight
cycle, settings, budget position). A strategy is created afresh for each
proposal and keeps no state: all that must survive a restart is in the
optimizer's JSON state.

Modules: optimizer (ask/tell, bookkeeping, surrogate cache, JSON state),
search (the ``Strategy`` protocol, ``History``, the strategies ``dycors``
and ``kriging_ei``), registry (strategy names -> classes, imported on first
use; the one list the settings validate), strategies (the pure math:
candidates, scores, expected improvement, step size), surrogates (fit/predict
models), designs (initial designs), early_termination, stopping, settings,
bounds.
"""

from __future__ import annotations

import importlib

# Names resolve on first use (PEP 562): the workflow's jobs validate the
# config with OptimizerSettings alone and skip the 0.9 s SciPy/SMT imports
# that the strategies and surrogates need.
_EXPORTS = {
    "Bounds": "bounds",
    "EarlyTerminationDecision": "early_termination",
    "EarlyTerminationSettings": "settings",
    "History": "search",
    "Optimizer": "optimizer",
    "OptimizerSettings": "settings",
    "Proposal": "optimizer",
    "Strategy": "search",
    "early_termination_decision": "early_termination",
    "register_strategy": "registry",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
