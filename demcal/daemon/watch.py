"""The early-termination watch (Samuelsson 2023, sec. 2.6 and 3.6.1).

``latest_estimates`` reads what running simulations have reported so far;
``evaluations_to_stop`` is the decision itself, a pure function of the
objective estimates and the optimizer's rule, so the loop feeds it and acts
on its answer.
"""

from __future__ import annotations

from collections.abc import Callable

from demcal.files import read_partial
from demcal.layout import EvaluationFiles
from demcal.optimizer import EarlyTerminationDecision


def latest_estimates(files: EvaluationFiles, scenes: list[str], replicates: int
                     ) -> dict[str, list[float]]:
    """Per ``scene.response``: the latest early estimate of each replicate that has one."""
    estimates: dict[str, list[float]] = {}
    for scene in scenes:
        for replicate in range(replicates):
            latest = {}
            for row in read_partial(files.replicate(scene, replicate).partial):
                if row["response"] is not None and row["value"] is not None:
                    latest[row["response"]] = row["value"]
            for response, value in latest.items():
                estimates.setdefault(f"{scene}.{response}", []).append(value)
    return estimates


def evaluations_to_stop(estimates: dict[str, float | None],
                        decide: Callable[[str, float], EarlyTerminationDecision]
                        ) -> dict[str, str]:
    """Running evaluations to stop, with the reason: those whose estimate the rule finds hopeless.

    ``estimates`` maps each watched evaluation to its objective estimate
    (None: nothing estimated yet); ``decide(evaluation, estimate)`` is the
    optimizer's early-termination rule.
    """
    stops = {}
    for evaluation, estimate in estimates.items():
        if estimate is None:
            continue
        decision = decide(evaluation, estimate)
        if decision.stop:
            stops[evaluation] = decision.reason
    return stops
