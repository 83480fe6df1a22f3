"""The early-termination watch (Samuelsson 2023, sec. 2.6 and 3.6.1).

``latest_estimates`` reads what running simulations have reported so far
(``partial_responses`` the same as the optimizer is told it for a stopped run);
``evaluations_to_stop`` is the decision itself, a pure function of the
objective estimates and the optimizer's rule, so the loop feeds it and acts
on its answer.
"""

from __future__ import annotations

from collections.abc import Callable

from demcal.files import read_partial
from demcal.layout import EvaluationFiles
from demcal.optimizer import EarlyTerminationDecision


def _latest(files: EvaluationFiles, scenes: list[str], replicates: int
            ) -> dict[str, list[tuple[float, bool]]]:
    """Per ``scene.response``: (value, final) of the latest report of each replicate that has one."""
    reports: dict[str, list[tuple[float, bool]]] = {}
    for scene in scenes:
        for replicate in range(replicates):
            latest = {}
            for row in read_partial(files.replicate(scene, replicate).partial):
                if row["response"] is not None and row["value"] is not None:
                    latest[row["response"]] = (row["value"], row["final"])
            for response, report in latest.items():
                reports.setdefault(f"{scene}.{response}", []).append(report)
    return reports


def latest_estimates(files: EvaluationFiles, scenes: list[str], replicates: int
                     ) -> dict[str, list[float]]:
    """Per ``scene.response``: the latest early estimate of each replicate that has one."""
    return {key: [value for value, _ in reports]
            for key, reports in _latest(files, scenes, replicates).items()}


def partial_responses(files: EvaluationFiles, scenes: list[str], replicates: int
                      ) -> dict[str, dict]:
    """What a stopped evaluation learnt, per response: its values and whether they were final."""
    return {key: {"values": [value for value, _ in reports],
                  "final": all(final for _, final in reports)}
            for key, reports in _latest(files, scenes, replicates).items()}


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
