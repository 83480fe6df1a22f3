"""Human-readable summaries of evaluation records for the terminal."""

from __future__ import annotations

import json
import math
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path

from demcal.errors import SimulationFailed
from demcal.optimizer.objective import Target, relative_miss
from demcal.results.layout import REUSED_ORIGINS
from demcal.results.records import FINE, BestRecord, ObjectiveRecord, Status
from demcal.snakemake_command import report_command
from demcal.study.model import Study


def time_unit(seconds: float) -> tuple[str, float]:
    """The unit that keeps a time reaching ``seconds`` readable (text or axis),
    and its size in s."""
    if seconds < 180:
        return "s", 1.0
    return ("min", 60.0) if seconds < 3 * 3600 else ("h", 3600.0)


def duration(seconds: float) -> str:
    """A time in words with its readable unit: 45 s, 22 min, 5.6 h."""
    unit, size = time_unit(seconds)
    return f"{seconds / size:.2g} {unit}" if seconds / size < 10 else f"{seconds / size:.0f} {unit}"


#: How the best point was chosen (``Optimizer.best()["chosen_by"]``), in words.
#: What the points of neighbouring materials are for, said wherever they are counted.
NEIGHBOURS_ROLE = "of neighbouring materials (data of the response models only)"
#: Why the answer and the lowest single run differ, said once wherever both are shown.
ANSWER_VERSUS_LOWEST_RUN = (
    "the answer is the point whose objective the models of all runs predict lowest; a single "
    "run scatters with the simulation's noise, so the lowest run may lie elsewhere"
)
CHOSEN_BY = {
    "response models": "lowest objective predicted from the response models",
    "objective surrogate": "lowest of observed and surrogate-predicted objective",
}


def with_sd(value: float | str | None, sd: float | None) -> str:
    """A value to 4 digits with its standard deviation, or a dash when there is none (None,
    or an empty field)."""
    if value is None or value == "":
        return "–"
    return f"{value:.4g}" + (f" ±{sd:.2g}" if sd else "")


def target_text(target: Target) -> str:
    """A target as the reports show it: its value ± spread, or its bounds."""
    return target.shown() if target.is_band else with_sd(target.value, target.spread)


def error_text(target: Target, simulated: float | None, error: float | None, unit: str) -> str:
    """A response's miss as the reports show it: in per cent of the value or bound it misses,
    or in the response's unit where that is 0 (a relative error of a 0 target is its absolute
    miss, ``relative_miss``)."""
    if simulated is None or error is None or not math.isfinite(error):
        return "–"
    if float(target.nearest(simulated)) == 0.0:
        return f"{error:+.3g} {unit}"
    return f"{100 * error:+.1f}%"


def _given(value: object) -> str:
    """A parameter value as recorded: a number to 4 digits, anything else (a hand-written
    params.json's text) as it was given."""
    is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
    return f"{value:.4g}" if is_number else repr(value)


def identification_verdicts(study: Study) -> dict[str, str]:
    """Each free parameter's verdict in the study's solutions.json ("pinned", "not
    identified", ...: ``demcal.analysis.solutions``); empty before the analysis has run."""
    try:
        summary = json.loads(study.files.solutions_summary.read_text())
        return {v["name"]: v["verdict"] for v in summary["verdicts"]}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def advised_test(advice: Path) -> str | None:
    """The top of ``demcal advise``'s ranking (its advice.json) in words; None before it has
    run (or when it is unreadable)."""
    try:
        ranking = json.loads(advice.read_text())["ranking"]
        return f"advised next (demcal advise): {ranking[0]['sentence']}" if ranking else None
    except (OSError, ValueError, KeyError, TypeError, IndexError):
        return None


def bound_advice(verdict: str | None, solutions_summary: Path) -> str:
    """What to do about a parameter on a bound of the answer, given what the targets identify:
    widening the bounds helps only a parameter the targets pin."""
    if verdict == "not identified":
        return (
            f"the targets do not identify it ({solutions_summary}), so other values meet them "
            "as well and wider bounds would not pin it; fix it at a measured value or add a "
            "lab test that is sensitive to it (demcal advise says which)"
        )
    if verdict is None:
        return (
            "the bounds may cut the solution off; widen them if the physics allows, unless "
            "`demcal solutions` finds that the targets do not identify it"
        )
    return "the bounds may cut the solution off; widen them if the physics allows"


def level_spending(study: Study) -> str | None:
    """The simulations and CPU time of each fidelity level, from evaluations.csv, as
    "fine 12 evaluations (13 min CPU), coarse 25 (4 min)"; None with one level."""
    import pandas as pd

    if not study.files.evaluations_csv.is_file():
        return None
    table = pd.read_csv(study.files.evaluations_csv)
    if "fidelity" not in table or table["fidelity"].nunique() < 2:
        return None
    if "origin" in table:  # the points reused from the archive cost this study nothing
        table = table[~table["origin"].isin(REUSED_ORIGINS)]
    cpu = pd.to_numeric(table["cpu_s"], errors="coerce").fillna(0.0)
    levels = sorted(table["fidelity"].unique(), key=lambda level: level != FINE)
    parts = [
        f"{level} {int((table['fidelity'] == level).sum())} evaluations "
        f"({duration(float(cpu[table['fidelity'] == level].sum()))} CPU)"
        for level in levels
    ]
    return "by level: " + ", ".join(parts)


def evaluation_summary(
    study: Study, record: ObjectiveRecord, where: Path, best: BestRecord | None = None
) -> str:
    """Status, parameters, responses against targets and objective of one evaluation.

    With ``best`` (best.json of this evaluation), each response also shows
    the response models' prediction ± sd there and the target ± spread, and
    parameters on a bound are flagged.
    """
    lines = [
        f"demcal: evaluation {record.evaluation!r} of study {study.name!r}: {record.status}"
        + (f", objective {record.objective:.4g}" if record.objective is not None else "")
    ]
    params = record.parameters
    units = {p.name: p.spec.unit for p in study.free if p.spec.unit != "-"}
    lines.append(
        "  parameters: "
        + (
            ", ".join(f"{k} = {_given(v)} {units.get(k, '')}".rstrip() for k, v in params.items())
            or "none recorded (see the reason)"
        )
    )
    verdicts = identification_verdicts(study)
    for name, side in ({} if best is None else best.on_bounds).items():
        bound = next(p for p in study.free if p.name == name)
        lines.append(
            f"  warning: {name} lies on its {side} bound "
            f"({bound.lower if side == 'lower' else bound.upper:g}): "
            + bound_advice(verdicts.get(name), study.files.solutions_summary)
        )
    predicted = {} if best is None else best.predicted_responses
    if record.status == Status.OK:
        header = f"  {'response':34s} {'simulated':>14s}"
        if predicted:
            header += f" {'predicted':>16s}"
        lines.append(header + f" {'target':>14s} {'error':>8s}")
        for t in study.targets:
            unit = study.scenes[t.scene].responses[t.response].unit
            line = (
                f"  {t.key + ' [' + unit + ']':34s} "
                f"{with_sd(record.responses[t.key], record.spread.get(t.key)):>14s}"
            )
            if predicted:
                line += f" {with_sd(predicted[t.key]['mean'], predicted[t.key]['sd']):>16s}"
            error = error_text(t, record.responses[t.key], record.relative_errors[t.key], unit)
            lines.append(line + f" {target_text(t):>14s} {error:>8s}")
    else:
        lines.append(f"  reason: {record.reason}")
    lines.append(f"  simulation CPU time {record.cost.get('cpu_s', 0):.0f} s; files in {where}/")
    return "\n".join(lines)


def confirmation_summary(study: Study, best: BestRecord) -> str | None:
    """The re-simulations of the best point (``confirm_replicates``) against the
    targets, or None."""
    confirmation = best.confirmation
    if not confirmation:
        return None
    lines = [
        f"confirmed by {len(confirmation['evaluations'])} more simulations of {confirmation['of']} "
        f"({', '.join(confirmation['evaluations'])}; {confirmation['failed']} failed, "
        f"{confirmation['pending']} still running):"
    ]
    for t in study.targets:
        entry = confirmation["responses"].get(t.key)
        if entry:
            unit = study.scenes[t.scene].responses[t.response].unit
            lines.append(
                f"  {t.key + ' [' + unit + ']':34s} mean "
                f"{with_sd(entry['mean'], entry['sd']):>16s} (n = {entry['count']})  target "
                f"{target_text(t)}  "
                f"{error_text(t, entry['mean'], relative_miss(t, entry['mean']), unit)}"
            )
    return "\n".join(lines)


def recent_summaries(study: Study, since: float) -> list[str]:
    """Summaries of the evaluations whose objective.json was written after ``since``."""
    out = []
    for evaluation in sorted(study.files.evals.glob("*"), key=lambda path: path.name):
        files = study.files.evaluation(evaluation.name)
        if files.objective.exists() and files.objective.stat().st_mtime >= since:
            try:
                out.append(evaluation_summary(study, ObjectiveRecord.read_latest(files), files.dir))
            except SimulationFailed as exc:
                out.append(f"demcal: {exc}")
    return out


def write_report(study: Study) -> str:
    """Run ``snakemake --report`` for the frozen study; return a line saying where it is."""
    report = study.files.report
    proc = subprocess.run(
        report_command(study.files.study, report),
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        tail = " | ".join(proc.stderr.strip().splitlines()[-3:])
        return f"demcal: the report could not be made ({tail}); figures in {report.parent}/plots/"
    return f"demcal: report: {report} (figures in {report.parent}/plots/)"


def posterior_line(intervals: Mapping[str, Sequence[float]], effective_samples: float) -> str:
    """The posterior's central 90 % interval per parameter in one line (``intervals``: name ->
    (low, high)), for those who read posteriors."""
    text = ", ".join(f"{name} {low:.3g}–{high:.3g}" for name, (low, high) in intervals.items())
    return (
        f"posterior (uniform prior over the bounds, Gaussian targets; {effective_samples:.0f} "
        f"effective samples), central 90 %: {text}"
    )
