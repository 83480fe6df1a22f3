"""demcal's optimizer: chooses where to simulate next. Pure Python, no files, no processes.

Methods: Samuelsson (2023) — symmetric Latin hypercube start, cubic RBF
surrogate with linear tail, MSRS/DYCORS candidate search, asynchronous
workers, early termination (Algorithms 3–5, Table 4.2); Rackl & Hanley
(2017) — universal Kriging with Matérn kernel, linear drift and nugget.

Public API (used by the daemon)::

    from demcal.optimizer import (
        Optimizer, OptimizerSettings, Proposal, Bounds, early_termination_decision,
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
    opt.best() -> {"x", "value", "predicted", "id"} | None
        # the evaluated point with the lowest surrogate prediction
    opt.early_termination(id, partial_estimate) -> EarlyTerminationDecision
    opt.stop_reason(elapsed_seconds) -> str | None
    opt.to_json() -> str;  Optimizer.from_json(s) -> Optimizer
        # same state, same next proposal

    early_termination_decision(best_value, partial_estimate, progress,
                               in_initial_design=False, enabled=True,
                               thresholds=(10, 5, 2.5),
                               progress_boundaries=(0.5, 0.75))
        # .stop is True when partial_estimate > c * best_value (thesis eq. 3.4)

Modules: designs (initial designs), surrogates (fit/predict models),
strategies (candidate generation and scoring), early_termination, stopping,
settings, bounds, optimizer (ask/tell/state).
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
    "Optimizer": "optimizer",
    "OptimizerSettings": "settings",
    "Proposal": "optimizer",
    "early_termination_decision": "early_termination",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
