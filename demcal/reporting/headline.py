"""The report's opening: the answer first (reStructuredText for Snakemake's report page).

Built from the study's result files when the report is made: why and when
the calibration ended, what it spent, the best parameters (with bounds, and
a warning on a bound), each response simulated / predicted ± sd / target ±
spread, what the targets identify (solutions.json) and the solution-space
and sensitivity figures, embedded so that the page is self-contained.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path
from typing import Any

import pandas as pd

from demcal.reporting.terminal import (
    ANSWER_VERSUS_LOWEST_RUN,
    CHOSEN_BY,
    NEIGHBOURS_ROLE,
    advised_test,
    duration,
    error_text,
    level_spending,
    posterior_line,
    target_text,
    with_sd,
)
from demcal.results.records import BestRecord, FinishedRecord, Status
from demcal.study.model import Study


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = [".. list-table::", "   :header-rows: 1", ""]
    for row in [header, *rows]:
        lines += [f"   * - {row[0]}", *(f"     - {cell}" for cell in row[1:])]
    return [*lines, ""]


def _image(path: Path) -> list[str]:
    if not path.exists():
        return []
    data = base64.b64encode(path.read_bytes()).decode()
    # docutils limits a line to 10000 characters; a URI may continue on indented lines (joined)
    return [
        ".. image::",
        *(
            f"   {data[i : i + 76]}" if i else f"   data:image/png;base64,{data[:76]}"
            for i in range(0, len(data), 76)
        ),
        "   :width: 100%",
        "",
    ]


def _read(path: Path) -> dict[str, Any] | None:
    try:
        record: dict[str, Any] | None = json.loads(path.read_text())  # a JSON object or null
        return record
    except (OSError, ValueError):
        return None


def report_headline(study: Study) -> str:
    """The report's first section as reStructuredText; says so when there is no result yet."""
    files = study.files
    lines = ["The answer", "==========", ""]
    finished = FinishedRecord.read_if_any(files.finished)
    if finished is None:
        return "\n".join(
            [*lines, "The calibration has not finished (no finished.json): run it first.", ""]
        )
    lines += _ended(study, finished)
    best = BestRecord.read_if_any(files.best)
    if best is None:
        return "\n".join(
            [*lines, "No evaluation succeeded: the reasons are in ``evaluations.csv``.", ""]
        )
    lines += _best_parameters(study, best) + _best_responses(study, best)
    lines += _confirmation(study, best) + _identified(files.solutions_summary, files.advice)
    lines += _image(files.plots / "solution_space.png") + _image(files.plots / "sensitivity.png")
    return "\n".join(lines)


def _ended(study: Study, finished: FinishedRecord) -> list[str]:
    """Why and when the calibration ended, and what it spent."""
    spent = ""
    if study.files.evaluations_csv.exists():
        cpu = pd.to_numeric(pd.read_csv(study.files.evaluations_csv)["cpu_s"], errors="coerce")
        spent = f"; simulation CPU time {duration(cpu.sum())}"
        spending = level_spending(study)
        spent += f" ({spending})" if spending else ""
    new, reused = "", ""
    if finished.reused is not None:
        new = " new"
        near = f", plus {finished.neighbours} {NEIGHBOURS_ROLE}" if finished.neighbours else ""
        reused = f" and {finished.reused} points reused from the archive{near} (``reused.json``)"
    return [
        f"**Ended:** {finished.reason}. **Evaluations:** {sum(finished.evaluations.values())}"
        f"{new} ({finished.count(Status.OK)} ok, {finished.count(Status.FAILED)} failed, "
        f"{finished.count(Status.TERMINATED)} stopped early){reused}{spent}.",
        "",
    ]


def _best_parameters(study: Study, best: BestRecord) -> list[str]:
    """The best parameters with their bounds, flagging one on a bound."""
    rows = []
    for p in study.free:
        unit = "" if p.spec.unit == "-" else f" {p.spec.unit}"
        side = best.on_bounds.get(p.name)
        note = f" **on its {side} bound**" if side else ""
        value = f"{best.parameters[p.name]:.4g}{unit}"
        rows.append([p.name, value, f"{p.lower:g} – {p.upper:g}{unit}{note}"])
    chosen_by = CHOSEN_BY.get(best.chosen_by or "", "lowest objective")
    reused = ", reused from the archive: simulated by that study on the same simulator"
    source = reused if best.reused else ""
    lowest = []
    if best.lowest_run is not None:
        lowest = [
            "",
            f"The lowest single run was ``{best.lowest_run['evaluation']}``, objective "
            f"{best.lowest_run['objective']:.4g}: {ANSWER_VERSUS_LOWEST_RUN}.",
        ]
    return [
        f"**Best parameters, the answer** (evaluation ``{best.evaluation}``{source}, "
        f"the evaluated point with the {chosen_by}):",
        "",
        *_table(["parameter", "value", "bounds"], rows),
        *lowest,
    ]


def _best_responses(study: Study, best: BestRecord) -> list[str]:
    """Each response at the best point: simulated, predicted ± sd, target ± spread, error."""
    rows = []
    for t in study.targets:
        unit = study.scenes[t.scene].responses[t.response].unit
        model = best.predicted_responses.get(t.key, {})
        rows.append(
            [
                f"{t.key} [{unit}]",
                with_sd(best.responses.get(t.key), None),
                with_sd(model.get("mean"), model.get("sd")),
                target_text(t),
                error_text(t, best.responses.get(t.key), best.relative_errors.get(t.key), unit),
            ]
        )
    unmeasured = study.replicates == 1 and not best.confirmation
    return [
        "**Responses against the targets** (simulated at the best point; predicted there by the "
        "response models ± their sd; target ± its measurement spread):",
        "",
        *_table(["response", "simulated", "predicted", "target", "error"], rows),
        *(
            [
                "",
                "No point was simulated twice, so the scatter of single simulations is not "
                "measured and the predicted sd may be too small: set "
                "``optimizer.confirm_replicates`` (e.g. 2) or ``replicates`` to measure it.",
            ]
            if unmeasured
            else []
        ),
    ]


def _confirmation(study: Study, best: BestRecord) -> list[str]:
    """The re-simulations of the best point, when there are any."""
    confirmation = best.confirmation
    if not confirmation or not confirmation["responses"]:
        return []
    rows = []
    for t in study.targets:
        entry = confirmation["responses"].get(t.key)
        if entry:
            mean = with_sd(entry["mean"], entry["sd"])
            rows.append([t.key, mean, str(entry["count"]), target_text(t)])
    return [
        f"**Confirmed** by {len(confirmation['evaluations'])} more simulations of the best "
        "point (new seeds; mean ± sd of their responses):",
        "",
        *_table(["response", "mean", "simulations", "target"], rows),
    ]


def _identified(solutions_summary: Path, advice: Path) -> list[str]:
    """What the targets identify (solutions.json), when the analysis has run, and the test
    ``demcal advise`` advised (advice.json), when it has."""
    solutions = _read(solutions_summary)
    if not solutions:
        return []
    posterior = solutions.get("posterior")
    advised = advised_test(advice)
    return [
        f"**What the targets identify** ({solutions['likely']} of {solutions['sampled']} "
        f"sampled parameter sets are likely to meet every target within {solutions['k']:g} sd, "
        f"{solutions['possible']} cannot be ruled out):",
        "",
        *[f"- {verdict['sentence']}" for verdict in solutions["verdicts"]],
        *(
            [f"- {posterior_line(posterior['interval_90'], posterior['effective_samples'])}"]
            if posterior
            else []
        ),
        *([f"- {advised}"] if advised else []),
        "",
    ]
