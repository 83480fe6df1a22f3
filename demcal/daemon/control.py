"""Acting on a calibration from outside its loop: stop it, send failed evaluations back."""

from __future__ import annotations

import fcntl
import json
import shutil

from demcal.daemon.tables import write_evaluations_csv
from demcal.errors import ConfigError, DemcalError, SimulationFailed
from demcal.files import atomic_write_text
from demcal.layout import PointRecord, evaluation_id, proposal_id, read_objective, read_point, write_point
from demcal.optimizer import Optimizer
from demcal.study import Study


def reopen_failed(study: Study) -> list[str]:
    """Mark every failed evaluation for a rerun with new seeds by the next daemon run.

    The optimizer forgets the failure (the point is pending again), the
    evaluation's outputs are removed and its attempt count goes on, so the
    rerun uses new seeds; finished.json goes too, so Snakemake's default
    target runs the daemon again.
    """
    files = study.files
    if not files.optimizer.exists():
        raise DemcalError(f"study {study.name!r} has not started ({files.optimizer} missing)")
    optimizer = Optimizer.from_json(files.optimizer.read_text())
    reopened = []
    for evaluation in files.evaluations():
        try:
            status = read_objective(evaluation).get("status")
        except SimulationFailed:
            continue
        if status != "failed":
            continue
        point = read_point(evaluation)
        optimizer.reopen(proposal_id(evaluation.id))
        for scene in study.scenes:
            shutil.rmtree(evaluation.scene_dir(scene), ignore_errors=True)
        for stale in (evaluation.objective, evaluation.stop, evaluation.launch):
            stale.unlink(missing_ok=True)
        point.attempt += 1
        write_point(evaluation, point)
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
        raise DemcalError(f"study {study.name!r} has not started ({files.optimizer} missing); "
                          f"start it first, or give the point in the initial design")
    names = [p.name for p in study.free]
    missing = [name for name in names if name not in values]
    unknown = [name for name in values if name not in names]
    if missing or unknown:
        raise ConfigError(f"the point needs a value for every free parameter ({', '.join(names)}): "
                          + (f"missing {', '.join(missing)}" if missing else f"unknown {', '.join(unknown)}"))
    for p in study.free:
        if not p.lower <= values[p.name] <= p.upper:
            raise ConfigError(f"{p.name}={values[p.name]:g} is outside its bounds [{p.lower:g}, {p.upper:g}]")
    optimizer = Optimizer.from_json(files.optimizer.read_text())
    proposal = optimizer.add_point([values[name] for name in names])
    evaluation = evaluation_id(proposal.id)
    write_point(files.evaluation(evaluation), PointRecord(dict(zip(names, proposal.x)), proposed_by="by hand"))
    atomic_write_text(files.optimizer, optimizer.to_json())
    files.finished.unlink(missing_ok=True)
    write_evaluations_csv(study)
    return evaluation


def request_stop(study: Study) -> None:
    """Make a running daemon stop proposing and stop running evaluations cleanly."""
    files = study.files
    files.dir.mkdir(parents=True, exist_ok=True)
    files.stop_calibration.touch()
    for evaluation in files.evals.glob("*"):
        evaluation_files = study.files.evaluation(evaluation.name)
        if evaluation_files.launch.exists() and not evaluation_files.objective.exists():
            evaluation_files.stop.touch()


def running_daemon(study: Study) -> int | None:
    """The pid of the daemon that holds the study's lock now, or None when none runs."""
    path = study.files.daemon_lock
    if not path.exists():
        return None
    with open(path) as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                return int(json.loads(path.read_text() or "{}").get("pid", 0)) or -1
            except ValueError:
                return -1
        fcntl.flock(lock, fcntl.LOCK_UN)
    return None
