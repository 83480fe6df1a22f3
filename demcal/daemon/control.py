"""Acting on a calibration from outside its loop: the daemon lock (who runs it), stop it, send
failed evaluations back, add a point by hand."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import time
from pathlib import Path
from typing import Any, TextIO

from demcal.daemon.launcher import alive
from demcal.daemon.tables import write_evaluations_csv
from demcal.errors import ConfigError, DemcalError, SimulationFailed
from demcal.jobs.steps import ask_to_stop
from demcal.optimizer import Optimizer
from demcal.results.layout import evaluation_id, proposal_id
from demcal.results.records import ObjectiveRecord, PointRecord, Status
from demcal.results.storage import atomic_write_text
from demcal.study.model import Study


def saved_optimizer(study: Study) -> Optimizer:
    """The optimizer as the calibration saved it (``optimizer.json``), with the study's objective.

    A DemcalError names the file when the study has not started or the state
    cannot be read.
    """
    path = study.files.optimizer
    if not path.is_file():
        raise DemcalError(f"{path} is missing: study {study.name!r} has not started")
    try:
        return Optimizer.from_json(path.read_text(), study.response_objective)
    except (ValueError, KeyError, TypeError) as exc:
        raise DemcalError(
            f"{path}: optimizer state unreadable ({exc}); "
            "move it away to start the calibration afresh"
        ) from None


def reopen_failed(study: Study) -> list[str]:
    """Mark every failed evaluation for a rerun with new seeds by the next daemon run.

    The optimizer forgets the failure (the point is pending again), the
    evaluation's outputs are removed and its attempt count goes on, so the
    rerun uses new seeds; finished.json goes too, so Snakemake's default
    target runs the daemon again.
    """
    files = study.files
    optimizer = saved_optimizer(study)
    reopened = []
    for evaluation in files.evaluations():
        try:
            status = ObjectiveRecord.read_latest(evaluation).status
        except SimulationFailed:
            continue
        if status != Status.FAILED:
            continue
        point = PointRecord.read(evaluation.params)
        optimizer.reopen(proposal_id(evaluation.id))
        for scene in study.scenes:
            shutil.rmtree(evaluation.scene_dir(scene), ignore_errors=True)
        for stale in (
            evaluation.objective,
            evaluation.rescored,
            evaluation.stop,
            evaluation.launch,
        ):
            stale.unlink(missing_ok=True)
        point.retried(None).write(evaluation.params)
        reopened.append(evaluation.id)
    atomic_write_text(files.optimizer, optimizer.to_json())
    files.finished.unlink(missing_ok=True)
    write_evaluations_csv(study)
    return reopened


def add_point(study: Study, values: dict[str, float]) -> str:
    """Queue a point given by hand for the next run; returns its evaluation id.

    Every free parameter needs a value within its bounds. The point becomes a
    pending evaluation of the optimizer (so it counts towards the budget and
    joins the models once simulated); finished.json goes, so the next run of
    the same command evaluates it.
    """
    files = study.files
    if not files.optimizer.exists():
        raise DemcalError(
            f"study {study.name!r} has not started ({files.optimizer} missing); "
            f"start it first, or give the point in the initial design"
        )
    names = [p.name for p in study.free]
    missing = [name for name in names if name not in values]
    unknown = [name for name in values if name not in names]
    if missing or unknown:
        raise ConfigError(
            f"the point needs a value for every free parameter ({', '.join(names)}): "
            + (f"missing {', '.join(missing)}" if missing else f"unknown {', '.join(unknown)}")
        )
    for p in study.free:
        if not p.lower <= values[p.name] <= p.upper:
            raise ConfigError(
                f"{p.name}={values[p.name]:g} is outside its bounds [{p.lower:g}, {p.upper:g}]"
            )
    optimizer = saved_optimizer(study)
    proposal = optimizer.add_point([values[name] for name in names])
    evaluation = evaluation_id(proposal.id)
    PointRecord(dict(zip(names, proposal.x)), proposed_by="by hand").write(
        files.evaluation(evaluation).params
    )
    atomic_write_text(files.optimizer, optimizer.to_json())
    files.finished.unlink(missing_ok=True)
    write_evaluations_csv(study)
    return evaluation


def explore_solutions(study: Study, evaluations: int) -> None:
    """Queue ``evaluations`` more simulations that map the solution set for the next run.

    The search for the best point ends if it had not; finished.json goes, so
    the next run of the same command simulates them.
    """
    optimizer = saved_optimizer(study)
    try:
        optimizer.explore(evaluations)
    except ValueError as exc:
        raise ConfigError(
            f"study {study.name!r}: {exc} (with rayleigh_cost_weight the optimizer works on "
            "objective values only)"
        ) from None
    atomic_write_text(study.files.optimizer, optimizer.to_json())
    study.files.finished.unlink(missing_ok=True)


def request_stop(study: Study) -> None:
    """Make a running daemon stop proposing and stop running evaluations cleanly."""
    files = study.files
    files.dir.mkdir(parents=True, exist_ok=True)
    files.stop_calibration.touch()
    for evaluation in files.evals.glob("*"):
        evaluation_files = study.files.evaluation(evaluation.name)
        running = evaluation_files.launch.exists() and not evaluation_files.objective.exists()
        if running and not evaluation_files.stop.exists():  # an early stop keeps its reason
            ask_to_stop(evaluation_files, "stopped by demcal stop")


#: Seconds to wait for the lock of a daemon whose Snakemake is gone (it ends within a poll).
ORPHAN_WAIT_SECONDS = 60.0


def lock_study(study: Study, watch_pid: int | None = None) -> TextIO:
    """Hold the study's daemon lock (released when the process ends, even by kill -9).

    The lock file names its holder and the Snakemake the holder watches. A
    holder whose Snakemake is gone is ending (``Calibration.check_parent``),
    so its lock is waited for; any other holder is a running calibration.
    """
    study.files.dir.mkdir(parents=True, exist_ok=True)
    path = study.files.daemon_lock
    lock = open(path, "a+")
    deadline = time.monotonic() + ORPHAN_WAIT_SECONDS
    while True:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            break
        except BlockingIOError:
            watched = _lock_holder(path).get("watch_pid")
            if watched is None or alive(int(watched)) or time.monotonic() > deadline:
                raise DemcalError(
                    f"another demcal daemon is running study {study.name!r} "
                    f"(lock {path}); 'demcal stop' ends it"
                ) from None
            time.sleep(0.5)
    lock.truncate(0)
    lock.write(json.dumps({"pid": os.getpid(), "watch_pid": watch_pid}))
    lock.flush()
    return lock


def _lock_holder(path: Path) -> dict[str, Any]:
    """What the lock file says of its holder: pid and watched Snakemake ({} if unreadable)."""
    try:
        holder = json.loads(path.read_text() or "{}")
    except (OSError, ValueError):
        return {}
    return holder if isinstance(holder, dict) else {}


def running_daemon(study: Study) -> int | None:
    """The pid of the daemon that holds the study's lock now (-1 if the file does not say),
    or None when none runs."""
    path = study.files.daemon_lock
    if not path.exists():
        return None
    with open(path) as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                return int(_lock_holder(path).get("pid", 0)) or -1
            except (TypeError, ValueError):
                return -1
        fcntl.flock(lock, fcntl.LOCK_UN)
    return None
