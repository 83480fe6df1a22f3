"""The live view of a running calibration: ``results/<study>/live.html``.

``demcal watch`` rewrites the page every few seconds while the daemon runs;
the page reloads itself in the browser. It shows the state and counts, the
running evaluations (simulation progress, objective estimate and the early
termination limit it is held to), the mismatch against run time and the
early-termination estimates over time (``demcal.reporting.figures``), from the files the
daemon keeps: nothing is asked of the daemon.
"""

from __future__ import annotations

import base64
import html
import io
import time
from collections.abc import Callable

import matplotlib.pyplot as plt
import pandas as pd

from demcal.daemon.control import saved_optimizer
from demcal.daemon.progress import clock
from demcal.reporting.figures import (
    evaluation_statuses,
    load_estimates,
    load_table,
    plot_early_termination,
    plot_objective_vs_time,
)
from demcal.results.layout import evaluation_id
from demcal.results.records import LaunchRecord
from demcal.results.storage import atomic_write_text, read_partial
from demcal.study.model import Study


def _png(draw: Callable[[io.BytesIO], object]) -> str:
    """An <img> of the figure that ``draw(out)`` saves to ``out``, embedded as a data URI."""
    buffer = io.BytesIO()
    draw(buffer)
    plt.close("all")
    return f'<img src="data:image/png;base64,{base64.b64encode(buffer.getvalue()).decode()}">'


def simulation_progress(study: Study, evaluation: str) -> float | None:
    """The least progress among an evaluation's simulations (None before any reported)."""
    files = study.files.evaluation(evaluation)
    latest = []
    for scene in study.scenes:
        for replicate in range(study.replicates):
            rows = read_partial(files.replicate(scene, replicate).partial)
            latest.append(rows[-1]["progress"] if rows else 0.0)
    return min(latest) if latest and any(latest) else None


def running_rows(study: Study, pending: list[str], estimates: pd.DataFrame) -> list[list[str]]:
    """Per running evaluation: its id, time running, progress, latest estimate and limit."""
    rows, now = [], time.time()
    for evaluation in pending:
        launch = LaunchRecord.read_if_any(study.files.evaluation(evaluation).launch)
        started = None if launch is None else launch.started_at
        progress = simulation_progress(study, evaluation)
        mine = estimates[estimates["evaluation"] == evaluation]
        estimate, limit = (
            ("–", "–")
            if mine.empty
            else (
                f"{mine['estimate'].iloc[-1]:.4g}",
                "not applied"
                if pd.isna(mine["limit"].iloc[-1])
                else f"{mine['limit'].iloc[-1]:.4g}",
            )
        )
        rows.append(
            [
                evaluation,
                "–" if started is None else clock(now - float(started)),
                "starting" if progress is None else f"{100 * progress:.0f} %",
                estimate,
                limit,
            ]
        )
    return rows


def live_page(study: Study, state: str, counts: str, refresh_s: float) -> str:
    """The page as HTML: state, running evaluations and the two live figures."""
    files = study.files
    optimizer = saved_optimizer(study)
    pending = [evaluation_id(i) for i in optimizer.pending()]
    estimates = load_estimates(study)
    parts = [
        f"<h1>demcal: {html.escape(study.name)}</h1>",
        f"<p><b>{html.escape(state)}</b><br>{html.escape(counts)}<br>"
        f"updated {time.strftime('%H:%M:%S')}, every {refresh_s:g} s</p>",
    ]
    rows = running_rows(study, pending, estimates)
    if rows:
        cells = "".join(
            "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>" for row in rows
        )
        parts.append(
            "<h2>Running</h2><table><tr><th>evaluation</th><th>running for</th><th>simulated</th>"
            "<th>estimated objective</th><th>early-termination limit</th></tr>"
            f"{cells}</table>"
        )
    if files.evaluations_csv.exists() and files.calibration.exists():
        table = load_table(study)
        parts.append(_png(lambda out: plot_objective_vs_time(study, table, out)))
        statuses = evaluation_statuses(table)
    else:
        statuses = {}
    parts.append(_png(lambda out: plot_early_termination(study, estimates, statuses, out)))
    style = (
        "body{font-family:sans-serif;margin:2em}img{max-width:100%;display:block}"
        "td,th{padding:2px 12px;text-align:right}"
    )
    return (
        f'<!DOCTYPE html><html><head><meta charset="utf-8">'
        f'<meta http-equiv="refresh" content="{refresh_s:g}">'
        f"<title>demcal {html.escape(study.name)}</title><style>{style}</style></head>"
        f"<body>{''.join(parts)}</body></html>\n"
    )


def write_live_page(study: Study, state: str, counts: str, refresh_s: float) -> None:
    atomic_write_text(study.files.live, live_page(study, state, counts, refresh_s))
