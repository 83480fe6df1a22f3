"""What a calibration exports while it runs: ``evaluations.csv`` and ``best.json``."""

from __future__ import annotations

import csv
import io

from demcal.errors import SimulationFailed
from demcal.files import atomic_write_text, write_json
from demcal.layout import evaluation_id, read_launch, read_objective, read_point
from demcal.study import Study


def write_evaluations_csv(study: Study) -> None:
    """One row per evaluation: parameters, responses per replicate, objective, status, cost."""
    names = [p.name for p in study.free]
    header = ["evaluation", "status", "reason", "objective", "attempts", *names,
              *[t.key for t in study.targets],
              *[f"{t.key}.rep{r}" for t in study.targets for r in range(study.replicates)],
              "started_at", "ended_at", "cpu_s"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=header, extrasaction="ignore")
    writer.writeheader()
    for files in study.files.evaluations():
        try:
            point = read_point(files)
        except SimulationFailed:
            continue
        try:
            record = read_objective(files)
            ended = files.objective.stat().st_mtime
        except (SimulationFailed, OSError):
            record, ended = {"status": "running"}, ""
        writer.writerow({
            "evaluation": files.id, "status": record.get("status"),
            "reason": record.get("reason", ""), "objective": record.get("objective", ""),
            "attempts": point.attempt + 1, **point.parameters,
            **record.get("responses", {}),
            **{f"{key}.rep{i}": value for key, values in record.get("replicates", {}).items()
               for i, value in enumerate(values)},
            "started_at": read_launch(files).get("started_at", ""), "ended_at": ended,
            "cpu_s": (record.get("cost") or {}).get("cpu_s", "")})
    atomic_write_text(study.files.evaluations_csv, buffer.getvalue())


def write_best(study: Study, best: dict, confirmation: dict | None = None) -> None:
    """best.json from the optimizer's best point (``Optimizer.best()``) and its records, with the
    re-simulations that confirm it (``Optimizer.confirmation()``) where there are any."""
    files = study.files.evaluation(evaluation_id(best["id"]))
    record = read_objective(files)
    write_json(study.files.best, {
        "evaluation": files.id, "parameters": dict(zip([p.name for p in study.free], best["x"])),
        "objective": best["value"], "predicted_objective": best["predicted"],
        "chosen_by": best["chosen_by"],
        "responses": record.get("responses", {}), "targets": record.get("targets", {}),
        "relative_errors": record.get("relative_errors", {}),
        "predicted_responses": {key: {"mean": mean, "sd": sd}
                                for key, (mean, sd) in best.get("responses", {}).items()},
        "target_spreads": {t.key: t.spread for t in study.targets},
        "on_bounds": {study.free[i].name: side for i, side in best["on_bounds"]},
        **({} if confirmation is None else {"confirmation": {
            "of": evaluation_id(confirmation["confirms"]),
            "evaluations": [evaluation_id(i) for i in confirmation["ids"]],
            "pending": confirmation["pending"], "failed": confirmation["failed"],
            "responses": confirmation["responses"]}})})
