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
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

from demcal.daemon.launcher import Running
from demcal.errors import DemcalError
from demcal.jobs.steps import ask_to_stop
from demcal.optimizer import (
    EarlyTerminationDecision,
    Optimizer,
    RunProgress,
    estimate_heading,
)
from demcal.results.layout import ESTIMATE_COLUMNS, EvaluationFiles, proposal_id
from demcal.results.records import PointRecord
from demcal.results.storage import LatestReports
from demcal.study.model import Study

log = logging.getLogger("demcal.daemon")


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
) -> dict[str, dict[str, Any]]:
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


def append_estimates(path: Path, rows: Sequence[tuple[object, ...]]) -> None:
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


class EarlyTerminationWatch:
    """The watch over a calibration's running evaluations (Samuelsson 2023, sec. 2.6): each
    poll, the objective estimate of every running evaluation from its replicates' early
    estimates, the optimizer's rule on it, a STOP file where it is hopeless, and each new
    estimate with its limit in early_termination.csv."""

    def __init__(
        self, study: Study, optimizer: Optimizer, started_at: float, stop_requested: set[str]
    ) -> None:
        self.study, self.optimizer, self.started_at = study, optimizer, started_at
        #: the calibration's evaluations asked to stop (shared with its loop)
        self.stop_requested = stop_requested
        #: (estimate, limit) last written to early_termination.csv, per evaluation
        self.recorded: dict[str, tuple[float | None, float | None]] = {}
        #: (share done, estimate, estimates reporting) of each running evaluation as it changed
        self.history: dict[str, list[tuple[float, float, int]]] = {}

    def forget(self, evaluation: str) -> None:
        """An evaluation that is no longer running: its estimates' trend is dropped."""
        self.history.pop(evaluation, None)

    def check(self, running: Mapping[str, Running]) -> None:
        """Stop the ``running`` evaluations whose partial objective is hopeless; record each
        new estimate with its limit."""
        if self.optimizer.best_observed is None:
            return
        watched = {
            evaluation: self.estimate(evaluation)
            for evaluation in running
            if evaluation not in self.stop_requested
        }

        def decide(evaluation: str, estimate: float) -> EarlyTerminationDecision:
            progress = self.run_progress(evaluation, estimate)
            return self.optimizer.early_termination(proposal_id(evaluation), estimate, progress)

        decisions = early_termination_decisions(watched, decide)
        now, rows = time.time(), []
        for evaluation, decision in decisions.items():
            if self.recorded.get(evaluation) != (watched[evaluation], decision.limit):
                self.recorded[evaluation] = (watched[evaluation], decision.limit)
                rows.append(
                    (
                        f"{now - self.started_at:.1f}",
                        evaluation,
                        f"{now - running[evaluation].started:.1f}",
                        f"{watched[evaluation]:.7g}",
                        "" if decision.limit is None else f"{decision.limit:.7g}",
                        int(decision.stop),
                        "" if decision.judged is None else f"{decision.judged:.7g}",
                    )
                )
            if decision.stop:
                ask_to_stop(
                    self.study.files.evaluation(evaluation),
                    f"stopped early by early termination: {decision.reason}",
                )
                self.stop_requested.add(evaluation)
                log.info("%s: early stop: %s", evaluation, decision.reason)
        append_estimates(self.study.files.early_termination, rows)

    def run_progress(self, evaluation: str, estimate: float) -> RunProgress:
        """Where a running evaluation stands: its share done and its estimate's heading. The
        trend starts anew whenever another simulation starts reporting (the estimate, a mean
        over the reporting ones, jumps then)."""
        files, scenes = self.study.files.evaluation(evaluation), list(self.study.scenes)
        done = share_done(files, scenes, self.study.replicates)
        estimates = partial_responses(files, scenes, self.study.replicates)
        reporting = sum(len(estimate["values"]) for estimate in estimates.values())
        history = self.history.setdefault(evaluation, [])
        if history and history[-1][2] != reporting:
            history.clear()
        if not history or history[-1][:2] != (done, estimate):
            history.append((done, estimate, reporting))
        heading = estimate_heading([(d, e) for d, e, _ in history])
        provisional = [key for key, estimate in estimates.items() if not estimate["final"]]
        return RunProgress(done, heading, tuple(sorted(estimates)), tuple(sorted(provisional)))

    def estimate(self, evaluation: str) -> float | None:
        """Objective estimate of a running evaluation from its replicates' early estimates."""
        files = self.study.files.evaluation(evaluation)
        cost = 0.0
        if self.study.rayleigh_cost_weight:
            try:
                cost = self.study.timestep_cost(PointRecord.read(files.params).parameters)
            except DemcalError:
                return None  # the evaluation will record why
        return self.study.objective.estimate(
            latest_estimates(files, list(self.study.scenes), self.study.replicates), cost
        )
