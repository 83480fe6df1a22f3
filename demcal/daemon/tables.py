"""What a calibration exports while it runs: ``evaluations.csv`` and ``best.json``."""

from __future__ import annotations

import csv
import io
from dataclasses import asdict
from datetime import UTC, datetime
from typing import TYPE_CHECKING

from demcal.errors import SimulationFailed
from demcal.jobs.steps import reused_objectives, reused_origins
from demcal.optimizer import Optimizer
from demcal.results.layout import REUSED_ORIGINS, evaluation_id
from demcal.results.records import (
    FINE,
    BestRecord,
    LaunchRecord,
    ObjectiveRecord,
    PointRecord,
    Status,
)
from demcal.results.storage import atomic_write_text
from demcal.study.model import Study

if TYPE_CHECKING:
    from demcal.optimizer.evaluation import BestPoint, Confirmation, Evaluation

#: Significant digits of the numbers in evaluations.csv (the JSON records keep every digit).
CSV_DIGITS = 7


def _number(value: object) -> str:
    return (
        f"{value:.{CSV_DIGITS}g}"
        if isinstance(value, float)
        else ("" if value is None else str(value))
    )


def iso_time(epoch: float | str | None) -> str:
    """A Unix time as ISO 8601 in UTC to the second, '' if unknown."""
    if epoch in ("", None):
        return ""
    return datetime.fromtimestamp(float(epoch), UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def evaluation_columns(study: Study) -> list[tuple[str, str, str]]:
    """(column, unit, meaning) of every column of evaluations.csv, in order."""
    units = {t.key: study.scenes[t.scene].responses[t.response].unit for t in study.targets}
    return [
        ("evaluation", "", "evaluation id (results/<study>/evals/<id>/)"),
        ("status", "", "ok, failed, terminated (stopped early) or pending (no result yet)"),
        (
            "origin",
            "",
            "new: simulated by this study in its search; confirmation: a re-simulation of the "
            "answer with new seeds; mapping: simulated to map the solution set; archive: reused "
            "from the archive (reused.json; evaluation is the study/evaluation that simulated it); "
            "neighbouring material: reused from the archive's runs of another material, which "
            "teach the response models (its objective is left empty: not this material's)",
        ),
        (
            "fidelity",
            "",
            f"the level it ran at: {FINE} (the study's own settings) or a cheaper one "
            f"(fidelities:), whose runs teach the fine response models only",
        ),
        ("reason", "", "why it failed or was stopped"),
        (
            "objective",
            "-",
            f"objective ({study.objective_form} form) of the replicate-mean responses",
        ),
        ("attempts", "", "runs of this point (retries after failures)"),
        *[(p.name, p.spec.unit, "free parameter") for p in study.free],
        *[(t.key, units[t.key], "replicate mean") for t in study.targets],
        *[
            (f"{t.key}.rep{r}", units[t.key], f"replicate {r}")
            for t in study.targets
            for r in range(study.replicates)
        ],
        ("started_at", "UTC", "launch time (ISO 8601)"),
        ("ended_at", "UTC", "time the objective was written (ISO 8601)"),
        ("wall_s", "s", "wall-clock time from launch to objective"),
        ("cpu_s", "s", "CPU time of the simulations"),
    ]


def write_evaluations_csv(study: Study) -> None:
    """One row per evaluation: parameters, responses per replicate, objective, status, cost.

    Units and meanings of the columns go to the sidecar evaluations.columns.csv.
    """
    columns = evaluation_columns(study)
    origins = _origins(study)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=[c for c, _, _ in columns], extrasaction="ignore")
    writer.writeheader()
    sources = reused_origins(study)
    for reused in reused_objectives(study):
        neighbour = bool(sources[reused.evaluation].material)
        row = {
            "evaluation": reused.evaluation,
            "status": reused.status,
            "origin": REUSED_ORIGINS[neighbour],
            "fidelity": sources[reused.evaluation].fidelity,
            "reason": reused.reason,
            "objective": None if neighbour else reused.objective,  # another material's
            **reused.parameters,
            **reused.responses,
            **_replicate_columns(reused),
        }
        writer.writerow({key: _number(value) for key, value in row.items()})
    for files in study.files.evaluations():
        try:
            point = PointRecord.read(files.params)
        except SimulationFailed:
            continue
        ended: float | None  # None while the objective is not written
        try:
            record = ObjectiveRecord.read_latest(files)
            ended = files.objective.stat().st_mtime
        except (SimulationFailed, OSError):
            record, ended = ObjectiveRecord(files.id, Status.PENDING), None
        launch = LaunchRecord.read_if_any(files.launch)
        started = None if launch is None else launch.started_at
        row = {
            "evaluation": files.id,
            "status": record.status,
            "origin": origins.get(files.id, "new"),
            "fidelity": point.level,
            "reason": record.reason,
            "objective": record.objective,
            "attempts": point.attempt + 1,
            **point.parameters,
            **record.responses,
            **_replicate_columns(record),
            "started_at": iso_time(started),
            "ended_at": iso_time(ended),
            "wall_s": ended - started if ended is not None and started is not None else None,
            "cpu_s": record.cost.get("cpu_s"),
        }
        writer.writerow({key: _number(value) for key, value in row.items()})
    atomic_write_text(study.files.evaluations_csv, buffer.getvalue())
    sidecar = io.StringIO()
    csv.writer(sidecar).writerows([("column", "unit", "meaning"), *columns])
    atomic_write_text(study.files.evaluations_columns, sidecar.getvalue())


def _origins(study: Study) -> dict[str, str]:
    """The evaluations the optimizer's records (``optimizer.json``) mark as re-simulations of
    the answer (``confirmation``) or as mapping the solution set (``mapping``), by id."""
    if not study.files.optimizer.is_file():
        return {}
    records = Optimizer.from_json(
        study.files.optimizer.read_text(), study.response_objective
    ).records
    return {
        evaluation_id(r.id): "confirmation" if r.confirms is not None else "mapping"
        for r in records
        if r.confirms is not None or r.maps_solutions
    }


def _replicate_columns(record: ObjectiveRecord) -> dict[str, float]:
    """The ``<response>.rep<i>`` columns of an evaluation."""
    return {
        f"{key}.rep{i}": value
        for key, values in record.replicates.items()
        for i, value in enumerate(values)
    }


def write_best(
    study: Study,
    best: BestPoint,
    confirmation: Confirmation | None = None,
    stop_reason: str | None = None,
    evaluations: dict[str, int] | None = None,
    taken: ObjectiveRecord | None = None,
    lowest: Evaluation | None = None,
) -> None:
    """best.json from the optimizer's best point (``Optimizer.best()``) and its records, with the
    re-simulations that confirm it (``Optimizer.confirmation()``) where there are any, the units
    of every parameter and response, why the calibration ended (None while it runs) and, with
    reuse, the ``evaluations`` new and reused. A reused best point is read from reused.json;
    ``taken``: the best point's outcome when the daemon took it before objective.json was
    written (``Calibration.taken_early``); ``lowest``: the point whose own runs scored lowest
    (``demcal.optimizer.best.lowest_run``), recorded where it is not the answer."""
    if best.reused_from is None:
        record = ObjectiveRecord.read_latest(study.files.evaluation(evaluation_id(best.id)), taken)
    else:
        record = next(r for r in reused_objectives(study) if r.evaluation == best.reused_from)
    BestRecord(
        evaluation=record.evaluation,
        stop_reason=stop_reason,
        parameters=dict(zip([p.name for p in study.free], best.x)),
        units={
            **{p.name: p.spec.unit for p in study.free},
            **{t.key: study.scenes[t.scene].responses[t.response].unit for t in study.targets},
        },
        objective=best.value,
        predicted_objective=best.predicted,
        chosen_by=best.chosen_by,
        responses=record.responses,
        targets={t.key: t.value for t in study.targets},
        relative_errors=record.relative_errors,
        predicted_responses={
            key: {"mean": mean, "sd": sd} for key, (mean, sd) in best.responses.items()
        },
        target_spreads={t.key: t.spread for t in study.targets},
        on_bounds={study.free[i].name: side for i, side in best.on_bounds},
        confirmation=None
        if confirmation is None
        else {
            "of": record.evaluation
            if confirmation.confirms == best.id
            else evaluation_id(confirmation.confirms),
            "evaluations": [evaluation_id(i) for i in confirmation.ids],
            "pending": confirmation.pending,
            "failed": confirmation.failed,
            "responses": {key: asdict(entry) for key, entry in confirmation.responses.items()},
        },
        reused=True if best.reused_from else None,
        evaluations=evaluations,
        lowest_run=None
        if lowest is None or lowest.id == best.id
        else {
            "evaluation": lowest.reused_from or evaluation_id(lowest.id),
            "objective": lowest.value,
        },
    ).write(study.files.best)
