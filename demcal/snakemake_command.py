"""demcal's Snakemake workflow as demcal itself runs it: every command line and profile fact.

Three Snakemake runs start from demcal code, all on the frozen study
(``--config study_file=...``, never the YAML) and built by
:func:`snakemake_command`:

- an evaluation's child (the daemon, one per evaluation): its run settings
  (``nolock``, ``rerun-incomplete``, ``rerun-triggers``, the executor, the
  logger) come from the profile, the local one when none is given;
- the report (``--report``), from the workflow's ``onsuccess``;
- an evaluation's DAG (``--dag``), from the ``evaluation_dag`` job.

The last two run inside a running Snakemake, so they take no directory lock.

Snakemake does not tell a workflow which profile or report it was started
with, so the Snakefile reads its own command line with
:func:`invocation_profile` and :func:`report_requested`.
"""

from __future__ import annotations

import functools
import os
import shutil
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import yaml

from demcal.errors import DemcalError
from demcal.resources import PROFILES_DIR, SNAKEFILE, WORKFLOW_DIR
from demcal.results.layout import ARCHIVED_FLAG

#: The profile of ``demcal run`` and of child Snakemakes when none is given.
LOCAL_PROFILE = PROFILES_DIR / "local"


def snakemake_command(
    study_file: Path | str,
    *arguments: str,
    profile: Path | None = None,
    cores: int | None = None,
) -> list[str]:
    """``python -m snakemake`` on demcal's Snakefile for the frozen study, then ``arguments``;
    a run on this machine's cores where no SLURM controller answers sees no SLURM
    configuration (:func:`slurm_unreachable`)."""
    command = [sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE)]
    command += ["--config", f"study_file={Path(study_file).resolve()}"]
    if profile is not None:
        command += ["--profile", str(profile)]
    if cores is not None:
        command += ["--cores", str(cores)]
    if runs_locally(profile) and slurm_unreachable():
        command = ["env", f"SLURM_CONF={os.devnull}", *command]
    return [*command, *arguments]


#: Seconds ``scontrol ping`` may take to say that a SLURM controller answers.
SLURM_PING_SECONDS = 5.0


@functools.lru_cache(maxsize=1)
def slurm_unreachable() -> bool:
    """True where SLURM's client is installed but no controller answers ``scontrol ping``
    (once per process).

    Snakemake loads every installed executor plugin, and the SLURM plugin then asks the
    controller for its settings (``scontrol show config``), which waits 10 s for a controller
    that does not answer: on every Snakemake start, so on every evaluation. A run on this
    machine's cores is then given an empty SLURM configuration (``SLURM_CONF=/dev/null``),
    and the question fails at once. Where a controller answers, or may (inside a SLURM job,
    or a ping that does not end in time), nothing changes, so a command engine that calls
    ``srun`` inside an allocation keeps working."""
    if shutil.which("scontrol") is None or "SLURM_JOB_ID" in os.environ:
        return False
    try:
        ping = subprocess.run(
            ["scontrol", "ping"],
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
            timeout=SLURM_PING_SECONDS,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return False  # slow, not absent: leave SLURM alone
    except OSError:
        return True
    return ping.returncode != 0 or "DOWN" in ping.stdout


def runs_locally(profile: Path | None) -> bool:
    """True if ``profile`` (None: none, as the report and DAG runs) runs jobs on this machine's
    cores, with Snakemake's local executor."""
    return profile is None or profile_settings(profile).get("executor", "local") == "local"


def child_command(
    study_file: Path | str, target: Path | str, profile: Path | None, cores: int | None
) -> list[str]:
    """The child Snakemake that builds one evaluation's ``target`` (its objective.json) and
    archives its simulations (the ``archived`` mark beside it)."""
    archived = Path(target).with_name(ARCHIVED_FLAG)
    return snakemake_command(
        study_file, str(target), str(archived), profile=profile or LOCAL_PROFILE, cores=cores
    )


#: demcal's stylesheet for Snakemake's report: pages start at the top, so the landing page
#: opens with the answer (Snakemake's centring hides the top of a page taller than the window).
REPORT_STYLESHEET = WORKFLOW_DIR / "report" / "report.css"


def report_command(study_file: Path | str, report: Path | str) -> list[str]:
    """``snakemake --report`` of the calibration (figures flagged in the rules), with
    :data:`REPORT_STYLESHEET`."""
    return snakemake_command(
        study_file,
        "--nolock",
        "--report",
        str(report),
        "--report-stylesheet",
        str(REPORT_STYLESHEET),
    )


def dag_command(study_file: Path | str, target: Path | str) -> list[str]:
    """The DAG of the jobs that build ``target``, in Graphviz's dot language on stdout (without
    the lock and past incomplete marks: it only reads, beside a running calibration)."""
    return snakemake_command(
        study_file, "--nolock", "--ignore-incomplete", "--dag", "dot", str(target)
    )


def profile_settings(profile: Path) -> dict[str, Any]:
    """The settings of a Snakemake profile (its config.yaml)."""
    path = Path(profile) / "config.yaml"
    try:
        settings = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise DemcalError(f"profile {profile}: cannot read {path}: {exc}") from None
    if not isinstance(settings, dict):
        raise DemcalError(f"profile {profile}: {path} holds no settings (name: value lines)")
    return settings


#: What demcal's crash safety needs of a profile, whatever else it sets: no directory lock
#: (the calibration holds its own), incomplete outputs rerun after a kill, and reruns
#: triggered by modification times only.
REQUIRED_PROFILE_SETTINGS = {"nolock": True, "rerun-incomplete": True, "rerun-triggers": "mtime"}


def check_profile(profile: Path | None) -> dict[str, Any]:
    """The settings of ``profile`` (None: the local profile, the one the children then run
    with); a profile that lacks a setting of :data:`REQUIRED_PROFILE_SETTINGS` is refused,
    naming it."""
    settings = profile_settings(profile or LOCAL_PROFILE)
    for name, wanted in REQUIRED_PROFILE_SETTINGS.items():
        given = settings.get(name)
        if given != wanted and given != [wanted]:
            raise DemcalError(
                f"profile {profile or LOCAL_PROFILE}: {name} is {given!r}; demcal's evaluations "
                f"need {name}: {str(wanted).lower() if isinstance(wanted, bool) else wanted} "
                f"(see profiles/local/config.yaml)"
            )
    return settings


def child_cores(settings: Mapping[str, Any], workers: int) -> int | None:
    """Cores each child Snakemake may use with a profile's ``settings``: none set on a cluster
    executor, else a fair share."""
    if settings.get("executor", "local") != "local":
        return None
    return max(1, (os.cpu_count() or 1) // workers)


def invocation_profile(argv: Sequence[str], environ: Mapping[str, str]) -> Path:
    """The ``--profile`` a Snakemake was started with (or ``$SNAKEMAKE_PROFILE``), else the
    local profile; absolute, so that the daemon's children find it from anywhere."""
    for i, arg in enumerate(argv):
        if arg == "--profile" and i + 1 < len(argv):
            return Path(os.path.abspath(argv[i + 1]))
        if arg.startswith("--profile="):
            return Path(os.path.abspath(arg.split("=", 1)[1]))
    return Path(os.path.abspath(environ.get("SNAKEMAKE_PROFILE", LOCAL_PROFILE)))


def report_requested(argv: Sequence[str]) -> bool:
    """Whether a Snakemake command line asks for the report."""
    return any(arg == "--report" or arg.startswith("--report=") for arg in argv)


class ScriptJob(Protocol):
    """What Snakemake hands a workflow script as ``snakemake`` (the parts used here)."""

    input: Sequence[str]
    output: Sequence[str]
    log: Sequence[str]
    params: Any  # the rule's params by name (study_file)
    wildcards: Any  # the job's wildcards by name (evaluation, scene, replicate)
