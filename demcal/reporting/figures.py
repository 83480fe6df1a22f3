"""Figures of a calibration, from results/<study>/evaluations.csv (for the report and notebooks).

- objective against evaluation number, with the best so far;
- objective against wall-clock time and against accumulated CPU time (error
  against run time);
- each free parameter against evaluation number (traces);
- each targeted response against evaluation number, with target and spread;
- parallel coordinates of the evaluated points, coloured by the objective;
- early termination: each watched run's objective estimate over its run
  time against the limit it was held to (early_termination.csv).
Early-stopped evaluations are marked with crosses on the lower edge, failed
ones with red bars: they have no objective.

Each ``plot_*`` function draws one figure and returns it (a matplotlib
``Figure``, shown as PNG when a notebook cell returns it); given a ``path``,
it also writes it there as PNG (``save_png``), as the report does. The
figures are drawn without pyplot: no window opens and no global state is
kept, in a job, a daemon thread or a notebook alike.
"""

from __future__ import annotations

import html
import io
import shutil
import subprocess
from pathlib import Path
from typing import BinaryIO

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from demcal.errors import SimulationFailed
from demcal.optimizer.bounds import to_unit_box
from demcal.optimizer.objective import PRECISION
from demcal.reporting.terminal import time_unit
from demcal.results.layout import (
    CALIBRATION_FILE,
    ESTIMATE_COLUMNS,
    REUSED_ORIGINS,
    proposal_id,
)
from demcal.results.records import FINE, BestRecord, SimulationRecord, Status
from demcal.results.storage import read_json
from demcal.snakemake_command import ScriptJob, dag_command
from demcal.study.model import Study, load_frozen

FIGURES = (
    "objective_vs_evaluation",
    "objective_vs_time",
    "parameter_traces",
    "responses_vs_targets",
    "parallel_coordinates",
    "early_termination",
)
#: Resolution of the figures' PNG files [dots per inch].
FIGURE_DPI = 110
STATUS_COLOURS: dict[str, str] = {
    Status.OK: "tab:blue",
    Status.TERMINATED: "tab:orange",
    Status.FAILED: "tab:red",
    Status.PENDING: "tab:green",
}


def load_table(study: Study) -> pd.DataFrame:
    """evaluations.csv with evaluation number, wall time since start and cumulative CPU time:
    the study's own evaluations at the fine level (the points reused from the archive have
    neither; a cheaper level's runs count in the CPU spent, but their objective is not the
    fine one's)."""
    table = pd.read_csv(study.files.evaluations_csv)
    if "origin" in table:  # tables written before reuse have no origin
        table = table[~table["origin"].isin(REUSED_ORIGINS)].reset_index(drop=True)
    table["number"] = table["evaluation"].map(proposal_id)  # as in the files: e0007 is 7
    start = pd.Timestamp(
        read_json(study.files.calibration, CALIBRATION_FILE)["started_at"], unit="s", tz="UTC"
    )
    table["ended_at"] = pd.to_datetime(table["ended_at"], utc=True, errors="coerce")
    table["cpu_s"] = pd.to_numeric(table["cpu_s"], errors="coerce").fillna(0.0)
    table["since_start_s"] = (table["ended_at"] - start).dt.total_seconds()
    order = table.sort_values("ended_at").index
    table.loc[order, "cpu_total_s"] = table.loc[order, "cpu_s"].cumsum()
    if "fidelity" in table:  # tables written before fidelity levels have none
        table = table[table["fidelity"].fillna(FINE) == FINE].reset_index(drop=True)
    return table


def objective_label(study: Study) -> str:
    """The objective's axis label in words, for the study's form."""
    if study.objective_form == PRECISION:
        return "mismatch with the targets\n(sum of squared errors in target spreads)"
    return "mismatch with the targets\n(sum of squared relative errors)"


#: Where a figure may be written: a file's path or a binary file open for writing.
PngTarget = Path | BinaryIO


class ReportFigure(Figure):
    """A figure of demcal's, drawn without pyplot; a notebook shows it as PNG."""

    def _repr_png_(self) -> bytes:
        buffer = io.BytesIO()
        save_png(self, buffer)
        return buffer.getvalue()


def new_figure(width: float, height: float) -> ReportFigure:
    """An empty figure of ``width`` by ``height`` inches."""
    return ReportFigure(figsize=(width, height))


def save_png(figure: Figure, path: PngTarget, dpi: int = FIGURE_DPI) -> None:
    """Write a drawn figure as PNG to ``path`` (a path or a binary file)."""
    figure.savefig(path, dpi=dpi, format="png")


def finish_figure(
    figure: ReportFigure,
    path: PngTarget | None,
    dpi: int = FIGURE_DPI,
    rect: tuple[float, float, float, float] = (0, 0, 1, 1),
) -> ReportFigure:
    """``figure`` laid out within ``rect`` (a share of its width and height), and written to
    ``path`` as PNG when there is one."""
    figure.tight_layout(rect=rect)
    if path is not None:
        save_png(figure, path, dpi)
    return figure


def _stacked(rows: int, height: float) -> tuple[ReportFigure, np.ndarray]:
    """A column of ``rows`` panels sharing the evaluation-number axis (an array of Axes)."""
    fig = new_figure(7, height * rows)
    axes = fig.subplots(rows, 1, sharex=True, squeeze=False)
    return fig, axes[:, 0]


def _finish_stack(fig: ReportFigure, axes: np.ndarray, path: PngTarget | None) -> ReportFigure:
    axes[0].legend(fontsize=7, ncol=4)
    axes[-1].set_xlabel("evaluation (number as in evals/e0000...)")
    return finish_figure(fig, path)


def _mark_unfinished(ax: Axes, table: pd.DataFrame, x: str) -> None:
    for status, marker, color in (
        (Status.TERMINATED, "x", "tab:orange"),
        (Status.FAILED, "|", "tab:red"),
    ):
        rows = table[table["status"] == status]
        if len(rows):
            ax.plot(
                rows[x],
                np.zeros(len(rows)),
                linestyle="none",
                markersize=9,
                transform=ax.get_xaxis_transform(),
                clip_on=False,
                label=f"{status} ({len(rows)})",
                marker=marker,
                color=color,
            )


def _objective_axes(ax: Axes, table: pd.DataFrame, x: str, xlabel: str, ylabel: str) -> None:
    ok = table[table["status"] == Status.OK].sort_values(x)
    ax.semilogy(ok[x], ok["objective"], "o", color="tab:blue", label="evaluated")
    ax.semilogy(ok[x], ok["objective"].cummin(), "-", color="black", label="best so far")
    _mark_unfinished(ax, table, x)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)


def plot_objective_vs_evaluation(
    study: Study, table: pd.DataFrame, path: PngTarget | None = None
) -> ReportFigure:
    """The objective of each evaluation against its number, with the best so far (``table``:
    `load_table`)."""
    fig = new_figure(7, 4)
    ax = fig.subplots()
    _objective_axes(
        ax, table, "number", "evaluation (number as in evals/e0000...)", objective_label(study)
    )
    ax.set_title(f"{study.name}: mismatch with the targets, evaluation by evaluation")
    return finish_figure(fig, path)


def plot_objective_vs_time(
    study: Study, table: pd.DataFrame, path: PngTarget | None = None
) -> ReportFigure:
    """The objective against wall-clock time and against the simulations' CPU time spent."""
    fig = new_figure(11, 4)
    axes = fig.subplots(1, 2, sharey=True)
    for ax, column, what in (
        (axes[0], "since_start_s", "wall-clock time since start"),
        (axes[1], "cpu_total_s", "simulation CPU time spent"),
    ):
        unit, size = time_unit(float(table[column].max()) if len(table) else 0.0)
        scaled = table.assign(**{column: table[column] / size})
        _objective_axes(ax, scaled, column, f"{what} [{unit}]", objective_label(study))
    fig.suptitle(f"{study.name}: error against run time")
    return finish_figure(fig, path)


def plot_parameter_traces(
    study: Study, table: pd.DataFrame, best: BestRecord | None, path: PngTarget | None = None
) -> ReportFigure:
    """Each free parameter against the evaluation number, within its bounds, the answer's value
    as a line."""
    fig, axes = _stacked(len(study.free), 2.2)
    for ax, p in zip(axes, study.free):
        for status, color in (
            (Status.OK, "tab:blue"),
            (Status.TERMINATED, "tab:orange"),
            (Status.FAILED, "tab:red"),
        ):
            rows = table[table["status"] == status]
            ax.plot(rows["number"], rows[p.name], "o", color=color, markersize=4, label=status)
        if best is not None:
            ax.axhline(best.parameters[p.name], color="black", lw=1, label="best")
        margin = 0.03 * (p.upper - p.lower)  # keep points on the bounds visible
        ax.set_ylim(p.lower - margin, p.upper + margin)
        for bound in (p.lower, p.upper):
            ax.axhline(bound, color="grey", lw=0.8, ls=":")
        unit = "" if p.spec.unit == "-" else f" [{p.spec.unit}]"
        ax.set_ylabel(p.name + unit, fontsize=8)
        ax.grid(True, alpha=0.3)
    return _finish_stack(fig, axes, path)


def plot_responses_vs_targets(
    study: Study, table: pd.DataFrame, best: BestRecord | None, path: PngTarget | None = None
) -> ReportFigure:
    """Each targeted response against the evaluation number, with its target (and spread or
    bounds) and the answer's evaluation as a star."""
    fig, axes = _stacked(len(study.targets), 2.4)
    ok = table[table["status"] == Status.OK]
    for ax, t in zip(axes, study.targets):
        unit = study.scenes[t.scene].responses[t.response].unit
        ax.plot(ok["number"], ok[t.key], "o", color="tab:blue", markersize=4, label="simulated")
        if t.lower is not None and t.upper is not None:
            ax.axhspan(t.lower, t.upper, color="green", alpha=0.15, label="target bounds")
        elif t.is_band:
            ax.axhline(t.value, color="green", lw=1.5, ls="--", label=f"bound ({t.shown()})")
        else:
            ax.axhline(t.value, color="green", lw=1.5, label="target")
        if t.spread and not t.is_band:
            ax.axhspan(
                t.value - t.spread,
                t.value + t.spread,
                color="green",
                alpha=0.15,
                label="measurement spread",
            )
        if best is not None:
            row = table[table["evaluation"] == best.evaluation]
            ax.plot(row["number"], row[t.key], "*", color="black", markersize=12, label="best")
        ax.set_ylabel(f"{t.key}\n[{unit}]", fontsize=8)
        ax.grid(True, alpha=0.3)
    return _finish_stack(fig, axes, path)


def plot_parallel_coordinates(
    study: Study, table: pd.DataFrame, best: BestRecord | None, path: PngTarget | None = None
) -> ReportFigure:
    """Every finished evaluation as a line across the free parameters (each axis its bounds),
    coloured by the objective: where the good points lie in all dimensions at once."""
    fig = new_figure(max(6.0, 1.6 * len(study.free)), 4.2)
    ax = fig.subplots()
    ok = table[table["status"] == Status.OK].sort_values("objective", ascending=False)
    lower, upper = [p.lower for p in study.free], [p.upper for p in study.free]
    scaled = to_unit_box(np.column_stack([ok[p.name] for p in study.free]), lower, upper)
    positions = np.arange(len(study.free))
    if len(ok):
        # poor in dark purple, the best last, in yellow
        colours = matplotlib.colormaps["viridis"](np.linspace(0.0, 1.0, len(ok)))
        for row, colour in zip(scaled, colours):
            ax.plot(positions, row, color=colour, alpha=0.6, lw=1)
    if best is not None:
        ax.plot(
            positions,
            to_unit_box([best.parameters[p.name] for p in study.free], lower, upper),
            color="red",
            lw=2.5,
            label="best point",
        )
        ax.legend(fontsize=8, loc="upper right")
    ax.set_xticks(
        positions, [f"{p.name}\n{p.lower:g} – {p.upper:g}" for p in study.free], fontsize=8
    )
    ax.set_ylim(-0.02, 1.02)
    ax.set_yticks([0, 1], ["lower bound", "upper bound"])
    ax.set_title(
        f"{study.name}: evaluated points, dark = poor match, yellow = good match", fontsize=10
    )
    return finish_figure(fig, path)


def load_estimates(study: Study) -> pd.DataFrame:
    """early_termination.csv (columns: ESTIMATE_COLUMNS); empty if none."""
    path = study.files.early_termination
    if not path.exists():
        return pd.DataFrame(columns=list(ESTIMATE_COLUMNS))
    return pd.read_csv(path)


def plot_early_termination(
    study: Study,
    estimates: pd.DataFrame,
    statuses: dict[str, str],
    path: PngTarget | None = None,
) -> ReportFigure:
    """The objective estimates of running evaluations over the calibration's time (points,
    joined per evaluation, coloured by how it ended) and the limit each was held to (dashed:
    c f* of the thesis' eq. 3.4, divided by the share of the run left under the weighed rule,
    so each run has its own); a cross where a run was stopped."""
    fig = new_figure(7, 4.2)
    ax = fig.subplots()
    if estimates.empty:
        ax.text(
            0.5,
            0.5,
            "no early estimates recorded\n(early termination off, or no run "
            "reported an estimate before it ended)",
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
        ax.set_axis_off()
        return finish_figure(fig, path)
    unit, size = time_unit(float(estimates["elapsed_s"].max()))
    shown: set[str] = set()
    limit_label: str | None = "limit it was held to"
    for evaluation, rows in estimates.groupby("evaluation", sort=True):
        status = statuses.get(str(evaluation), Status.PENDING)
        label = None if status in shown else "running" if status == Status.PENDING else status
        shown.add(status)
        colour = STATUS_COLOURS.get(status, "grey")
        ax.semilogy(
            rows["elapsed_s"] / size,
            rows["estimate"],
            "-o",
            color=colour,
            markersize=3,
            lw=0.8,
            label=label,
        )
        limits = rows.dropna(subset=["limit"])
        if len(limits):
            ax.step(
                limits["elapsed_s"] / size,
                limits["limit"],
                "--",
                where="post",
                color=colour,
                lw=0.8,
                label=limit_label,
            )
            limit_label = None
    stopped = estimates[estimates["stop"] == 1]
    if len(stopped):
        ax.plot(
            stopped["elapsed_s"] / size,
            stopped["estimate"],
            "x",
            color="black",
            markersize=9,
            label=f"stopped ({len(stopped)})",
        )
    ax.set_xlabel(f"time since the calibration started [{unit}]")
    ax.set_ylabel("estimated " + objective_label(study))
    ax.set_title(f"{study.name}: early termination, estimates of running evaluations", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return finish_figure(fig, path)


def evaluation_statuses(table: pd.DataFrame) -> dict[str, str]:
    return dict(zip(table["evaluation"], table["status"]))


def write_plots(study: Study, outdir: Path) -> list[Path]:
    """All figures of the calibration as PNG files in ``outdir``."""
    outdir.mkdir(parents=True, exist_ok=True)
    table = load_table(study)
    best = BestRecord.read_if_any(study.files.best)
    paths = {name: outdir / f"{name}.png" for name in FIGURES}
    plot_objective_vs_evaluation(study, table, paths["objective_vs_evaluation"])
    plot_objective_vs_time(study, table, paths["objective_vs_time"])
    plot_parameter_traces(study, table, best, paths["parameter_traces"])
    plot_responses_vs_targets(study, table, best, paths["responses_vs_targets"])
    plot_parallel_coordinates(study, table, best, paths["parallel_coordinates"])
    plot_early_termination(
        study, load_estimates(study), evaluation_statuses(table), paths["early_termination"]
    )
    return list(paths.values())


def answer_runs(study: Study, best: BestRecord) -> list[str]:
    """The evaluations that simulated the answer: its own and its confirmations (none for
    an answer taken from the archive, whose files are another study's)."""
    if best.reused:
        return []
    return [best.evaluation, *((best.confirmation or {}).get("evaluations") or [])]


def answer_histories(
    study: Study, best: BestRecord
) -> dict[str, list[tuple[np.ndarray, np.ndarray]]]:
    """Per ``scene.response``, the (times, values) of every saved run of the answer, from the
    scenes that keep a time series (``Scene.history``)."""
    series: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for name, scene in study.scenes.items():
        if scene.history is None:
            continue
        for evaluation in answer_runs(study, best):
            for replicate in range(study.replicates):
                files = study.files.evaluation(evaluation).replicate(name, replicate)
                try:
                    settings = SimulationRecord.read(files.simulation).settings
                    with np.load(files.state) as data:
                        state = {key: data[key] for key in data.files}
                except (SimulationFailed, OSError, ValueError):
                    continue  # not run, failed, or no state kept: nothing to draw
                for response, run in scene.history(state, settings).items():
                    series.setdefault(f"{name}.{response}", []).append(run)
    return series


def plot_answer_history(
    study: Study, best: BestRecord | None, path: PngTarget | None = None
) -> ReportFigure:
    """The responses of the answer over simulated time: the mean and ±1 sd over its runs
    (replicates and confirmations), as Samuelsson (2023, Figure 5.5b) shows the flows of his
    chute's answer."""
    fig = new_figure(7.0, 4.0)
    ax = fig.subplots()
    series = {} if best is None else answer_histories(study, best)
    for key, runs in series.items():
        length = min(len(times) for times, _ in runs)
        times = np.asarray(runs[0][0][:length], float)
        values = np.array([np.asarray(v, float)[:length] for _, v in runs])
        mean = values.mean(axis=0)
        sd = values.std(axis=0, ddof=1) if len(runs) > 1 else np.zeros(length)
        (line,) = ax.plot(times, mean, lw=1.5, label=f"{key} (mean of {len(runs)} runs)")
        ax.fill_between(times, mean - sd, mean + sd, color=line.get_color(), alpha=0.2)
    if series:
        scene, response = next(iter(series)).split(".", 1)
        ax.set_ylabel(f"[{study.scenes[scene].responses[response].unit}]")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no saved run of an answer", ha="center", transform=ax.transAxes)
    ax.set_xlabel("simulated time [s]")
    answer = "no answer" if best is None else f"the answer, {best.evaluation}"
    ax.set_title(f"{answer}: responses over time (band: ±1 sd)", fontsize=9)
    ax.grid(True, alpha=0.3)
    return finish_figure(fig, path)


def write_answer_history(smk: ScriptJob) -> None:
    """Entry point of the workflow's answer_history job."""
    study = load_frozen(smk.params.study_file)
    plot_answer_history(study, BestRecord.read_if_any(study.files.best), Path(smk.output[0]))


#: The columns of the answer's table (`answer_table`; best.csv).
ANSWER_COLUMNS = [
    "quantity",
    "value",
    "predicted",
    "predicted_sd",
    "target",
    "target_spread",
    "relative_error_percent",
    "unit",
    "note",
]


def answer_table(study: Study, best: BestRecord) -> pd.DataFrame:
    """The answer against the targets, a row per quantity: each free parameter (``note``: on
    which bound, if on one), each targeted response (simulated, predicted by the response
    models with their sd, target and spread, relative error) and the objective; None where a
    column does not apply."""
    rows = [
        {
            "quantity": p.name,
            "value": best.parameters[p.name],
            "note": f"on its {best.on_bounds[p.name]} bound" if p.name in best.on_bounds else None,
            "unit": p.spec.unit,
        }
        for p in study.free
    ]
    predicted = best.predicted_responses
    for t in study.targets:
        rows.append(
            {
                "quantity": t.key,
                "value": best.responses.get(t.key),
                "predicted": predicted.get(t.key, {}).get("mean"),
                "predicted_sd": predicted.get(t.key, {}).get("sd"),
                "target": t.shown() if t.is_band else t.value,
                "target_spread": t.spread,
                "relative_error_percent": 100 * best.relative_errors.get(t.key, np.nan),
                "unit": study.scenes[t.scene].responses[t.response].unit,
            }
        )
    rows.append(
        {
            "quantity": "objective",
            "value": best.objective,
            "predicted": best.predicted_objective,
            "target": 0,
            "unit": "-",
        }
    )
    return pd.DataFrame(rows).reindex(columns=ANSWER_COLUMNS)


def best_point_table(study: Study) -> pd.DataFrame:
    """best.csv: `answer_table` with empty cells, or a row saying there is no answer yet."""
    if not study.files.best.exists():
        return pd.DataFrame(
            [
                {
                    "quantity": "no evaluation succeeded (see evaluations.csv)",
                    "value": "",
                    "target": "",
                    "relative_error_percent": "",
                    "unit": "",
                }
            ]
        )
    return answer_table(study, BestRecord.read(study.files.best)).astype(object).fillna("")


def write_report_files(smk: ScriptJob) -> None:
    """Entry point of the workflow's plots job."""
    import logging

    logging.basicConfig(filename=smk.log[0], level=logging.INFO, force=True)
    study = load_frozen(smk.params.study_file)
    best_csv = Path(smk.output[0])
    write_plots(study, best_csv.parent)
    best_point_table(study).to_csv(best_csv, index=False)


def dag_svg(dot_source: str) -> str:
    """Render DOT with Graphviz; without it, an SVG that says how to get the drawing."""
    if shutil.which("dot") is None:
        lines = [
            "Graphviz is not installed (apt install graphviz): DAG not drawn.",
            "DOT source:",
        ] + dot_source.splitlines()
        text = "".join(
            f'<text x="10" y="{20 + 16 * i}" font-family="monospace" '
            f'font-size="12">{html.escape(line)}</text>'
            for i, line in enumerate(lines)
        )
        return (
            f'<svg xmlns="http://www.w3.org/2000/svg" width="900" '
            f'height="{40 + 16 * len(lines)}">{text}</svg>\n'
        )
    proc = subprocess.run(
        ["dot", "-Tsvg"], input=dot_source, capture_output=True, text=True, check=True, timeout=120
    )
    return proc.stdout


def simulated_evaluation(study: Study) -> Path:
    """The objective.json of the study's first evaluation that it simulated itself: a point
    reused from the archive has an id but no params.json, so no DAG to draw."""
    for evaluation in study.files.evaluations():
        if evaluation.params.is_file():
            return evaluation.objective
    raise SystemExit(f"{study.files.evals}: no evaluation of this study to draw")


def write_evaluation_dag(smk: ScriptJob) -> None:
    """Entry point of the workflow's evaluation_dag job."""
    target = simulated_evaluation(load_frozen(smk.params.study_file))
    proc = subprocess.run(
        dag_command(smk.params.study_file, target),
        capture_output=True,
        text=True,
        check=False,
        stdin=subprocess.DEVNULL,
        timeout=300,
    )
    Path(smk.log[0]).write_text(proc.stderr)
    if proc.returncode != 0 or "digraph" not in proc.stdout:
        raise SystemExit(f"snakemake --dag failed (see {smk.log[0]})")
    dot_source = proc.stdout[proc.stdout.index("digraph") :]
    Path(smk.output[0]).write_text(dag_svg(dot_source))
