"""``demcal run``: run (or resume) a calibration, and its closing answer (the best point)."""

from __future__ import annotations

import argparse
import contextlib
import csv
import logging
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO

from demcal.cli.options import evaluation_arguments
from demcal.cli.study_argument import study_yaml
from demcal.daemon.session import DAEMON_LOG_FORMAT, calibrate, locked_study
from demcal.errors import DemcalError
from demcal.jobs.steps import reused_objectives
from demcal.reporting.terminal import (
    ANSWER_VERSUS_LOWEST_RUN,
    CHOSEN_BY,
    NEIGHBOURS_ROLE,
    confirmation_summary,
    evaluation_summary,
    level_spending,
)
from demcal.results.layout import StudyFiles
from demcal.results.records import BestRecord, ObjectiveRecord, ReusedRecord
from demcal.study.model import Study


def run(args: argparse.Namespace) -> int:
    with _log_file(args.log) as log:
        try:
            return _run(args, log)
        except (DemcalError, OSError) as exc:  # main() prints it; the log keeps it too
            if log is not None:
                print(f"demcal: {exc}", file=log, flush=True)
            raise


def _run(args: argparse.Namespace, log: TextIO | None) -> int:
    profile = Path(args.profile) if args.profile else None
    config = args.config if args.frozen else study_yaml(args.config, "run")
    with locked_study(config, args.frozen, args.watch_pid, log) as study:
        logging.basicConfig(
            filename=study.files.daemon_log,
            level=logging.INFO,
            format=DAEMON_LOG_FORMAT,
        )
        try:
            reason = calibrate(study, profile, args.workers, args.watch_pid, log)
        except KeyboardInterrupt:
            return 130
        print(f"demcal: calibration of {study.name!r} finished: {reason}")
        print_best(study)
        if not args.frozen and study.files.best.exists() and not study.files.report.exists():
            # the workflow's calibrate rule (--frozen) makes the report itself
            print(f"report: demcal report {study.name} makes {study.files.report}")
    return 0


@contextlib.contextmanager
def _log_file(path: str | None) -> Iterator[TextIO | None]:
    """The --log file opened for appending (None without one)."""
    if path is None:
        yield None
        return
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as log:
        yield log


def print_best(study: Study) -> None:
    files = study.files
    if not files.best.exists():
        print(
            f"demcal: no evaluation succeeded{_commonest_failure(files)}; every reason is in "
            f"{files.evaluations_csv}"
        )
        return
    best = BestRecord.read(files.best)
    print(
        f"the answer ({CHOSEN_BY.get(best.chosen_by or '', 'lowest objective')} among the "
        f"evaluated points):"
    )
    if best.reused:  # simulated by another study: read from reused.json, its folder is that study's
        source, evaluation_name = best.evaluation.split("+")[0].split("/")
        record = next(
            (r for r in reused_objectives(study) if r.evaluation == best.evaluation), None
        )
        if record is None:
            print(
                f"{best.evaluation}, reused from the archive; {files.reused} no longer holds it: "
                f"run the study again to rebuild it"
            )
            return
        print(
            evaluation_summary(
                study, record, StudyFiles.of(source).evaluation(evaluation_name).dir, best
            )
        )
        archive = ReusedRecord.read(files.reused).archive
        print(
            f"(reused from the archive {archive}: simulated by {best.evaluation} on the same "
            f"simulator; {files.reused})"
        )
    else:
        evaluation = files.evaluation(best.evaluation)
        print(
            evaluation_summary(study, ObjectiveRecord.read_latest(evaluation), evaluation.dir, best)
        )
    if best.predicted_responses:
        print(
            "(simulated: this evaluation, ± spread of its replicates; predicted: the response "
            "models there, ± their sd; target ± its spread)"
        )
    confirmed = confirmation_summary(study, best)
    if confirmed:
        print(confirmed)
    if best.lowest_run is not None:
        print(
            f"lowest single run: {best.lowest_run['evaluation']}, objective "
            f"{best.lowest_run['objective']:.4g} ({ANSWER_VERSUS_LOWEST_RUN})"
        )
    if best.evaluations is not None:
        near = best.evaluations.get("neighbours")
        neighbours = "" if near is None else f" and {near} {NEIGHBOURS_ROLE}"
        print(
            f"evaluations: {best.evaluations['new']} new, {best.evaluations['reused']} points "
            f"reused from the archive{neighbours} ({files.reused})"
        )
    spending = level_spending(study)
    if spending:
        print(f"simulations {spending}; the answer and its confirmations are fine runs")
    print(f"all evaluations: {files.evaluations_csv}")


def _commonest_failure(files: StudyFiles) -> str:
    """ ", most often: REASON (n of N)" from evaluations.csv; "" when it has none."""
    try:
        with open(files.evaluations_csv, newline="", encoding="utf-8") as handle:
            reasons = [row["reason"] for row in csv.DictReader(handle) if row.get("reason")]
    except (OSError, ValueError, KeyError, csv.Error):
        return ""
    if not reasons:
        return ""
    reason, count = Counter(reasons).most_common(1)[0]
    return f", most often: {reason!r} ({count} of {len(reasons)})"


def arguments(sub: argparse.ArgumentParser) -> None:
    evaluation_arguments(sub)
    # set by the workflow's calibrate rule: the daemon ends with its Snakemake
    sub.add_argument("--watch-pid", type=int, help=argparse.SUPPRESS)
    # set by the calibrate rule too: the config is the study.json it froze
    sub.add_argument("--frozen", action="store_true", help=argparse.SUPPRESS)
    sub.add_argument(
        "--log", help="also append the messages and a progress line every 30 s to this file"
    )
