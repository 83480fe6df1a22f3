"""The optimizer's saved state (``optimizer.json``): what :meth:`~.optimizer.Optimizer.to_json`
writes and :meth:`~.optimizer.Optimizer.from_json` reads back.

One JSON object, format version 1: the bounds, settings, seed, workers,
initial design (its size and the points not yet handed out), the records (and with a
cheaper fidelity level its records and what is left of its initial design; with
neighbouring materials their points),
the next id, the step size, the weight index, the best value and the
evaluations without improvement, the random generator's state, and, when
present, what the strategy remembers (``strategy_state``) and the version of
the objective it scored responses with (the targets themselves live in the
study, ``study.json``; states written before kept a copy of them). Resuming
from it, with the objective, gives the same next proposal.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import numpy as np

from demcal.optimizer.objective import ResponseObjective

from .bounds import Bounds
from .candidates import StepSize
from .evaluation import Evaluation
from .settings import OptimizerSettings

if TYPE_CHECKING:
    from .optimizer import Optimizer

STATE_VERSION = 1


def encode(optimizer: Optimizer) -> str:
    """The optimizer's state as JSON text."""
    state = {
        "version": STATE_VERSION,
        "lower": list(optimizer.bounds.lower),
        "upper": list(optimizer.bounds.upper),
        "settings": optimizer.settings.to_dict(),
        "seed": optimizer.seed,
        "workers": optimizer.workers,
        "initial_size": optimizer.initial_size,
        "design_queue": optimizer.design_queue,
        "records": [record.to_dict() for record in optimizer.records],
        "next_id": optimizer.next_id,
        "step": {
            "sigma": optimizer.step.sigma,
            "successes": optimizer.step.successes,
            "failures": optimizer.step.failures,
            "collapsed": optimizer.step.collapsed,
        },
        "weight_index": optimizer.weight_index,
        "best_observed": optimizer.best_observed,
        "evaluations_without_improvement": optimizer.evaluations_without_improvement,
        "rng": optimizer.rng.bit_generator.state,
    }
    if optimizer.cheap_records or optimizer.cheap_queue:
        state["cheap_records"] = [record.to_dict() for record in optimizer.cheap_records]
        state["cheap_queue"] = optimizer.cheap_queue
    if optimizer.neighbour_records:
        state["neighbour_records"] = [record.to_dict() for record in optimizer.neighbour_records]
    if optimizer.strategy_state:
        state["strategy_state"] = optimizer.strategy_state
    if optimizer.search_ended is not None:
        state["search_ended"] = optimizer.search_ended
    if optimizer.explore_more:
        state["explore_more"] = optimizer.explore_more
    if optimizer.objective is not None:
        state["objective_version"] = optimizer.objective.version
    return json.dumps(state)


def decode(text: str, objective: ResponseObjective | None) -> dict[str, Any]:
    """The saved attributes of an optimizer by name, from :func:`encode`'s text, with
    ``objective`` (or the copy a state written before kept).

    Raises ValueError for another format version, and for a state that scored
    responses when no objective is given.
    """
    state = json.loads(text)
    if state.get("version") != STATE_VERSION:
        raise ValueError(f"optimizer state version {state.get('version')!r} is not {STATE_VERSION}")
    if objective is None and "objective" in state:
        objective = ResponseObjective.from_dict(state["objective"])
    if objective is None and "objective_version" in state:
        raise ValueError(
            f"the optimizer scored responses with objective {state['objective_version']}; "
            "give from_json that objective (e.g. the study's)"
        )
    rng = np.random.default_rng()
    rng.bit_generator.state = state["rng"]
    return {
        "bounds": Bounds.of(state["lower"], state["upper"]),
        "settings": OptimizerSettings.from_dict(state["settings"]),
        "seed": state["seed"],
        "workers": state["workers"],
        "rng": rng,
        "initial_size": state["initial_size"],
        "design_queue": state["design_queue"],
        "records": [Evaluation.from_dict(record) for record in state["records"]],
        "cheap_records": [Evaluation.from_dict(r) for r in state.get("cheap_records", [])],
        "cheap_queue": state.get("cheap_queue", []),
        "neighbour_records": [Evaluation.from_dict(r) for r in state.get("neighbour_records", [])],
        "next_id": state["next_id"],
        "step": StepSize(**state["step"]),
        "weight_index": state["weight_index"],
        "best_observed": state["best_observed"],
        "evaluations_without_improvement": state["evaluations_without_improvement"],
        "strategy_state": state.get("strategy_state", {}),
        "search_ended": state.get("search_ended"),
        "explore_more": state.get("explore_more", 0),
        "objective": objective,
    }
