"""A calibration session: the study read, checked, frozen and locked, and its daemon run to
the end with one child Snakemake per evaluation. ``demcal run`` and the Python API's
``Study.run`` both go through here."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, TextIO

from demcal.daemon.control import lock_study
from demcal.daemon.launcher import SnakemakeLauncher
from demcal.daemon.loop import Calibration
from demcal.daemon.progress import ProgressDisplay
from demcal.errors import ConfigError
from demcal.snakemake_command import check_profile, child_cores
from demcal.study.config import check_study_name, load_study_file
from demcal.study.model import Study, freeze, load_frozen

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


@contextlib.contextmanager
def locked_study(
    config: str | Path,
    frozen: bool = False,
    watch_pid: int | None = None,
    log: TextIO | None = None,
    name: str | None = None,
    replicates: int | None = None,
) -> Iterator[Study]:
    """The study of ``config`` as its jobs will read it, with the study's daemon lock held
    inside the block. A YAML is validated, its warnings said, and frozen under the lock; with
    ``frozen`` (the workflow's calibrate rule), ``config`` is the study.json it froze. ``name``
    renames the study of a YAML (``demcal sample --name``), ``replicates`` sets its seeds per
    point (``demcal fidelity check``)."""
    study = load_frozen(config) if frozen else load_study_file(config)
    if name is not None:
        study.name = check_study_name(name, "--name")
    if replicates is not None:
        study.replicates = replicates
    with contextlib.closing(lock_study(study, watch_pid)):
        if not frozen:
            for warning in study.warnings:
                say(f"demcal: warning: {warning}", log)
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
        say(
            f"demcal: interrupted; {len(calibration.children)} evaluations keep running "
            f"and are collected by the next 'demcal run' ('demcal stop' stops them)",
            log,
        )
        raise
    display.close()
    return reason


def say(message: str, log: TextIO | None = None) -> None:
    """A message on stderr, and in the log if there is one."""
    for stream in (sys.stderr, log):
        if stream is not None:
            print(message, file=stream, flush=True)
