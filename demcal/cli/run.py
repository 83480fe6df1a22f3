"""``demcal run``: run (or resume) a calibration, and its closing answer (the best point)."""

from __future__ import annotations

import argparse
import contextlib
import logging
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, TextIO

import pandas as pd

from demcal.cli.study_argument import study_yaml
from demcal.daemon.control import lock_study
from demcal.daemon.launcher import SnakemakeLauncher
from demcal.daemon.loop import Calibration
from demcal.daemon.progress import ProgressDisplay
from demcal.errors import ConfigError, DemcalError
from demcal.jobs.evaluation import reused_objectives
from demcal.reporting.terminal import (
    ANSWER_VERSUS_LOWEST_RUN,
    CHOSEN_BY,
    confirmation_summary,
    evaluation_summary,
)
from demcal.results.layout import StudyFiles
from demcal.results.records import BestRecord, ObjectiveRecord, ReusedRecord
from demcal.study.config import check_study_name, load_study_file
from demcal.study.model import Study, freeze, load_frozen
from demcal.workflow import check_profile, child_cores

#: Lines of the calibration's daemon.log.
DAEMON_LOG_FORMAT = "%(asctime)s %(levelname)s %(message)s"

#: Evaluations in flight when neither the study, the command line nor the profile says.
DEFAULT_WORKERS = 2


def workers_of(study: Study, settings: Mapping[str, Any], given: int | None) -> tuple[int, str]:
    """Evaluations in flight, and what set them: --workers, else calibration.workers, else the
    jobs of the profile's ``settings``, else 2."""
    if given is not None and given < 1:
        raise ConfigError(f"--workers {given}: give at least 1 (evaluations in flight)")
    for value, source in (
        (given, "--workers"),
        (study.calibration.get("workers"), "calibration.workers"),
        (settings.get("jobs"), "the profile's jobs"),
    ):
        if value:
            return int(value), source
    return DEFAULT_WORKERS, "the default"


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
def locked_study(
    config: str | Path,
    frozen: bool = False,
    watch_pid: int | None = None,
    log: TextIO | None = None,
    name: str | None = None,
) -> Iterator[Study]:
    """The study of ``config`` as its jobs will read it, with the study's daemon lock held
    inside the block. A YAML is validated, its warnings said, and frozen under the lock; with
    ``frozen`` (the workflow's calibrate rule), ``config`` is the study.json it froze. ``name``
    renames the study of a YAML (``demcal sample --name``)."""
    study = load_frozen(config) if frozen else load_study_file(config)
    if name is not None:
        study.name = check_study_name(name, "--name")
    with contextlib.closing(lock_study(study, watch_pid)):
        if not frozen:
            for warning in study.warnings:
                _say(f"demcal: warning: {warning}", log)
            study = freeze(study)  # from here on: the study as the jobs read it
        yield study


def calibrate(
    study: Study,
    profile: Path | None,
    workers: int | None = None,
    watch_pid: int | None = None,
    log: TextIO | None = None,
) -> str:
    """Run the calibration of a frozen study whose lock is held (:func:`locked_study`) until it
    ends, one child Snakemake per evaluation with ``profile``; return why it ended.

    The progress goes to stderr (and ``log``). An interrupt (Ctrl-C) says what keeps running
    and is raised again."""
    settings = check_profile(profile)
    workers, _ = workers_of(study, settings, workers)
    launcher = SnakemakeLauncher(study.files.study, profile, child_cores(settings, workers))
    calibration = Calibration(study, launcher, workers, watch_pid=watch_pid)
    display = ProgressDisplay(sys.stderr, log)
    try:
        reason = calibration.run(display)
    except KeyboardInterrupt:
        display.close()
        _say(
            f"demcal: interrupted; {len(calibration.children)} evaluations keep running "
            f"and are collected by the next 'demcal run' ('demcal stop' stops them)",
            log,
        )
        raise
    display.close()
    return reason


@contextlib.contextmanager
def _log_file(path: str | None) -> Iterator[TextIO | None]:
    """The --log file opened for appending (None without one)."""
    if path is None:
        yield None
        return
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as log:
        yield log


def _say(message: str, log: TextIO | None = None) -> None:
    """A message on stderr, and in the log if there is one."""
    for stream in (sys.stderr, log):
        if stream is not None:
            print(message, file=stream, flush=True)


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
        print(
            f"evaluations: {best.evaluations['new']} new, {best.evaluations['reused']} points "
            f"reused from the archive ({files.reused})"
        )
    print(f"all evaluations: {files.evaluations_csv}")


def _commonest_failure(files: StudyFiles) -> str:
    """ ", most often: REASON (n of N)" from evaluations.csv; "" when it has none."""
    try:
        reasons = pd.read_csv(files.evaluations_csv)["reason"].dropna()
    except (OSError, ValueError, KeyError):
        return ""
    if reasons.empty:
        return ""
    counts = reasons.value_counts()
    return f", most often: {counts.index[0]!r} ({counts.iloc[0]} of {len(reasons)})"
