"""Child processes of the daemon: one child Snakemake per evaluation.

Starting a child (its command, its log, ``launch.json`` with its pid),
finding out whether a process is alive and which Snakemake it is (``/proc``),
and the Snakemake profile settings the children inherit.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from demcal.errors import DemcalError
from demcal.resources import SNAKEFILE
from demcal.results.layout import EvaluationFiles
from demcal.results.storage import write_json


@dataclass
class Child:
    """A running child Snakemake of one evaluation (ours, or re-attached after a restart)."""

    evaluation: str
    pid: int
    process: subprocess.Popen | None
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


def child_command(
    study_file: Path, target: Path, profile: Path | None, cores: int | None
) -> list[str]:
    """The child Snakemake that builds one evaluation's objective from the frozen study."""
    command = [
        sys.executable,
        "-m",
        "snakemake",
        "-s",
        str(SNAKEFILE),
        "--config",
        f"study_file={Path(study_file).resolve()}",
        "--nolock",
        "--rerun-incomplete",
        "--rerun-triggers",
        "mtime",
        "--quiet",
        "rules",
    ]
    if profile is not None:
        command += ["--profile", str(profile)]
    if cores is not None:
        command += ["--cores", str(cores)]
    return command + [str(target)]


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
    now = time.time()
    write_json(files.launch, {"pid": process.pid, "started_at": now})
    return Child(files.id, process.pid, process, now)


def profile_settings(profile: Path | None) -> dict:
    """The settings of a Snakemake profile (its config.yaml), {} without a profile."""
    if profile is None:
        return {}
    path = Path(profile) / "config.yaml"
    try:
        return yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise DemcalError(f"profile {profile}: cannot read {path}: {exc}") from None


def child_cores(profile: Path | None, workers: int) -> int | None:
    """Cores each child Snakemake may use: none set on a cluster executor, else a fair share."""
    if profile_settings(profile).get("executor", "local") != "local":
        return None
    return max(1, (os.cpu_count() or 1) // workers)
