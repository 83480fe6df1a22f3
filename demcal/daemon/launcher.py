"""How the daemon runs an evaluation: the ``Launcher`` protocol and its Snakemake launcher.

The calibration loop (:class:`demcal.daemon.loop.Calibration`) hands each
evaluation to a launcher and polls what it gets back (``Running``) until
it has finished; the evaluation's outcome is then its objective record on
disk. :class:`SnakemakeLauncher` starts one child Snakemake per evaluation
(command: :func:`demcal.snakemake_command.child_command`) in its own session, with
``launch.json`` holding its pid, and re-attaches to a child that outlived
an earlier daemon (``/proc`` tells whether the pid is still that
Snakemake). Tests give the loop a launcher that runs the jobs in-process.
"""

from __future__ import annotations

import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from demcal.results.layout import EvaluationFiles
from demcal.results.records import LaunchRecord
from demcal.snakemake_command import child_command


class Running(Protocol):
    """An evaluation being run: its process (pid, or -1 when none), when it started (Unix s)
    and whether it has ended."""

    evaluation: str
    pid: int
    started: float

    def finished(self) -> bool: ...

    def returncode(self) -> int | None: ...


class Launcher(Protocol):
    """Runs evaluations for the calibration loop."""

    def launch(self, files: EvaluationFiles) -> Running:
        """Start building ``files.objective`` from ``files.params``."""
        ...

    def reattach(self, files: EvaluationFiles) -> Running | None:
        """The run of an evaluation still going from an earlier daemon, else None."""
        ...


@dataclass
class Child:
    """A running child Snakemake of one evaluation (ours, or re-attached after a restart)."""

    evaluation: str
    pid: int
    process: subprocess.Popen[bytes] | None
    started: float

    def finished(self) -> bool:
        if self.process is not None:
            return self.process.poll() is not None
        return not alive(self.pid)

    def returncode(self) -> int | None:
        return None if self.process is None else self.process.returncode


def alive(pid: int) -> bool:
    """True if ``pid`` is a live process that is not a zombie."""
    try:
        status = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return status.rsplit(")", 1)[1].split()[0] != "Z"


def is_snakemake_for(pid: int, target: str) -> bool:
    """True if ``pid`` is a Snakemake building ``target`` (not a reused pid)."""
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return False
    return any(b"snakemake" in part for part in cmdline) and target.encode() in cmdline


def start_child(files: EvaluationFiles, command: list[str]) -> Child:
    """Start an evaluation's child Snakemake in its own session; record its pid in launch.json."""
    files.logs.mkdir(parents=True, exist_ok=True)
    with open(files.snakemake_log, "a") as out:
        process = subprocess.Popen(
            command,
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    launch = LaunchRecord(process.pid, time.time())
    launch.write(files.launch)
    return Child(files.id, process.pid, process, launch.started_at)


@dataclass(frozen=True)
class SnakemakeLauncher:
    """One child Snakemake per evaluation on the frozen study, with the calibration's profile
    (None: the local one) and ``cores`` per child (None: as the profile says)."""

    study_file: Path
    profile: Path | None = None
    cores: int | None = None

    def launch(self, files: EvaluationFiles) -> Child:
        return start_child(
            files, child_command(self.study_file, files.objective, self.profile, self.cores)
        )

    def reattach(self, files: EvaluationFiles) -> Child | None:
        launch = LaunchRecord.read_if_any(files.launch)
        if (
            launch is not None
            and launch.pid > 0
            and alive(launch.pid)
            and is_snakemake_for(launch.pid, str(files.objective))
        ):
            return Child(files.id, launch.pid, None, launch.started_at)
        return None
