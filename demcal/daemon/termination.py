"""The early-termination watch (Samuelsson 2023, sec. 2.6 and 3.6.1).

``latest_estimates`` reads what running simulations have reported so far
(``partial_responses`` the same as the optimizer is told it for a stopped run),
each poll reading on from where the last one stopped in each ``partial.csv``;
``share_done`` says how much of an evaluation's simulation work is behind it;
``early_termination_decisions`` applies the optimizer's rule to the objective
estimates, so the loop feeds it and acts on its answer; ``append_estimates``
keeps the estimates and limits over time in ``early_termination.csv`` (the
live view and the report draw them).
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

from demcal.optimizer import EarlyTerminationDecision
from demcal.results.layout import ESTIMATE_COLUMNS, EvaluationFiles
from demcal.results.storage import LatestReports


@lru_cache(maxsize=4096)  # far more files than simulations run at once; one evicted starts over
def _reports(path: Path) -> LatestReports:
    """The reports of one partial.csv, kept between polls so that each reads only what is new."""
    return LatestReports(path)


def _latest(
    files: EvaluationFiles, scenes: list[str], replicates: int
) -> dict[str, list[tuple[float, bool]]]:
    """Per ``scene.response``: (value, final) of the latest report of each
    replicate that has one."""
    reports: dict[str, list[tuple[float, bool]]] = {}
    for scene in scenes:
        for replicate in range(replicates):
            replicate_reports = _reports(files.replicate(scene, replicate).partial)
            replicate_reports.read_on()
            for response, report in replicate_reports.latest.items():
                reports.setdefault(f"{scene}.{response}", []).append(report)
    return reports


def forget_reports() -> None:
    """Drop what was read of every partial.csv (an evaluation retried starts its files anew)."""
    _reports.cache_clear()


def share_done(files: EvaluationFiles, scenes: list[str], replicates: int) -> float:
    """The share of an evaluation's simulations behind it: a finished one (its responses.json
    written) counts 1, a running one its latest progress, one not started 0; all weigh alike."""
    shares = []
    for scene in scenes:
        for replicate in range(replicates):
            replicate_files = files.replicate(scene, replicate)
            if replicate_files.responses.exists():
                shares.append(1.0)
                continue
            reports = _reports(replicate_files.partial)
            reports.read_on()
            shares.append(reports.progress)
    return sum(shares) / len(shares)


def latest_estimates(
    files: EvaluationFiles, scenes: list[str], replicates: int
) -> dict[str, list[float]]:
    """Per ``scene.response``: the latest early estimate of each replicate that has one."""
    return {
        key: [value for value, _ in reports]
        for key, reports in _latest(files, scenes, replicates).items()
    }


def partial_responses(
    files: EvaluationFiles, scenes: list[str], replicates: int
) -> dict[str, dict]:
    """What a stopped evaluation learnt, per response: its values and whether they were final."""
    return {
        key: {
            "values": [value for value, _ in reports],
            "final": all(final for _, final in reports),
        }
        for key, reports in _latest(files, scenes, replicates).items()
    }


def early_termination_decisions(
    estimates: dict[str, float | None], decide: Callable[[str, float], EarlyTerminationDecision]
) -> dict[str, EarlyTerminationDecision]:
    """The rule's decision for every watched evaluation that has an objective estimate.

    ``estimates`` maps each watched evaluation to its objective estimate
    (None: nothing estimated yet); ``decide(evaluation, estimate)`` is the
    optimizer's early-termination rule.
    """
    return {
        evaluation: decide(evaluation, estimate)
        for evaluation, estimate in estimates.items()
        if estimate is not None
    }


#: Columns of early_termination.csv: one row each time a running evaluation's estimate changes.
#: ``limit``: what the estimate was held to (empty: none applied); ``judged``: the estimate
#: compared with it (the estimate, or where its falling trend heads).


def append_estimates(path: Path, rows: list[tuple]) -> None:
    """Append rows (``ESTIMATE_COLUMNS``) to the study's early-termination trace; a trace begun
    by an earlier demcal keeps its own columns."""
    if not rows:
        return
    new = not path.exists()
    width = len(ESTIMATE_COLUMNS)
    if not new:
        with open(path, newline="") as handle:
            width = len(next(csv.reader(handle), ESTIMATE_COLUMNS))
    with open(path, "a", newline="") as handle:
        writer = csv.writer(handle)
        if new:
            writer.writerow(ESTIMATE_COLUMNS)
        writer.writerows(row[:width] for row in rows)
