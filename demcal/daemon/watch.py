"""The early-termination watch (Samuelsson 2023, sec. 2.6 and 3.6.1).

``latest_estimates`` reads what running simulations have reported so far
(``partial_responses`` the same as the optimizer is told it for a stopped run);
``early_termination_decisions`` applies the optimizer's rule to the objective
estimates, so the loop feeds it and acts on its answer; ``append_estimates``
keeps the estimates and limits over time in ``early_termination.csv`` (the
live view and the report draw them).
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path

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


def early_termination_decisions(estimates: dict[str, float | None],
                                 decide: Callable[[str, float], EarlyTerminationDecision]
                                 ) -> dict[str, EarlyTerminationDecision]:
    """The rule's decision for every watched evaluation that has an objective estimate.

    ``estimates`` maps each watched evaluation to its objective estimate
    (None: nothing estimated yet); ``decide(evaluation, estimate)`` is the
    optimizer's early-termination rule.
    """
    return {evaluation: decide(evaluation, estimate)
            for evaluation, estimate in estimates.items() if estimate is not None}


#: Columns of early_termination.csv: one row each time a running evaluation's estimate changes.
ESTIMATE_COLUMNS = ("elapsed_s", "evaluation", "running_s", "estimate", "limit", "stop")


def append_estimates(path: Path, rows: list[tuple]) -> None:
    """Append rows (``ESTIMATE_COLUMNS``) to the study's early-termination trace."""
    if not rows:
        return
    new = not path.exists()
    with open(path, "a", newline="") as handle:
        writer = csv.writer(handle)
        if new:
            writer.writerow(ESTIMATE_COLUMNS)
        writer.writerows(rows)
