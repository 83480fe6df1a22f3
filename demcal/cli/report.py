"""``demcal report [STUDY]``: the figures and report.html of a finished calibration, made as
the workflow's own route makes them (``snakemake --profile ...`` on a finished study)."""

from __future__ import annotations

import argparse
import subprocess
import time
from pathlib import Path

from demcal.cli.study_argument import study_of
from demcal.daemon.control import running_daemon
from demcal.errors import DemcalError
from demcal.reporting.terminal import write_report
from demcal.snakemake_command import LOCAL_PROFILE, snakemake_command
from demcal.study.model import Study


def report(args: argparse.Namespace) -> int:
    study = study_of(args.config)
    refuse_unfinished(study, args.config)
    start = time.time()
    # The workflow's default target: the plots and solutions rules draw the figures of a
    # finished calibration, and its onsuccess makes report.html once they are new.
    done = subprocess.run(
        snakemake_command(study.files.study, profile=LOCAL_PROFILE),
        stdin=subprocess.DEVNULL,
        check=False,
    )
    if done.returncode != 0:
        raise DemcalError(
            f"the figures of {study.name!r} could not be made (Snakemake ended with "
            f"{done.returncode}; the logs of its jobs are in {study.files.logs}/)"
        )
    report_file = study.files.report
    if not report_file.exists() or report_file.stat().st_mtime < start:
        print(write_report(study))  # the figures were up to date: only the report is made
    return 0 if report_file.exists() and report_file.stat().st_mtime >= start else 1


def refuse_unfinished(study: Study, given: str) -> None:
    """A DemcalError saying what to do when the calibration of ``study`` has not finished."""
    if study.files.finished.exists():
        return
    again = given if Path(given).is_file() else "STUDY.yaml"
    if not study.files.optimizer.exists():
        raise DemcalError(
            f"study {study.name!r} has not run yet: 'demcal run {again}' calibrates it, "
            f"then 'demcal report {study.name}' makes its report"
        )
    daemon = running_daemon(study)
    if daemon is not None:
        raise DemcalError(
            f"study {study.name!r} is still running (daemon pid {daemon}): its report can be "
            f"made once it has finished ('demcal status {study.name}' shows how far it is)"
        )
    raise DemcalError(
        f"the calibration of {study.name!r} has not finished (interrupted, or points were "
        f"added since): 'demcal run {again}' finishes it, then 'demcal report {study.name}'"
    )
