"""The calibration's figures, drawn from an evaluations table written by hand."""

from __future__ import annotations

import csv
import io
import json

import matplotlib.image
import numpy as np
import pytest
from helpers import analytic_example
from matplotlib.figure import Figure

from demcal.reporting.figures import (
    FIGURES,
    answer_table,
    best_point_table,
    load_table,
    plot_objective_vs_evaluation,
    save_png,
    write_plots,
)
from demcal.results.layout import ESTIMATE_COLUMNS
from demcal.results.records import BestRecord
from demcal.study.config import load_study

START = 1_700_000_000.0  # calibration.json's started_at: 2023-11-14T22:13:20Z
COLUMNS = [
    "evaluation",
    "status",
    "reason",
    "objective",
    "sliding_friction_pp",
    "rolling_friction_pp",
    "cylinder_lift.angle_of_repose",
    "cylinder_lift.bulk_density",
    "ended_at",
    "cpu_s",
]
ROWS = [
    ["e0000", "ok", "", "0.21", "0.82", "0.10", "34.5", "1404", "2023-11-14T22:14:20Z", "30"],
    ["e0001", "ok", "", "0.0085", "0.34", "0.05", "22.7", "1470", "2023-11-14T22:14:50Z", "20"],
    ["e0002", "ok", "", "0.096", "0.50", "0.16", "32.7", "1389", "2023-11-14T22:14:30Z", "25"],
    [
        "e0003",
        "terminated",
        "stopped early",
        "",
        "0.66",
        "0.27",
        "",
        "",
        "2023-11-14T22:15:00Z",
        "5",
    ],
    ["e0004", "failed", "injected", "", "0.15", "0.10", "", "", "2023-11-14T22:15:10Z", "3"],
    ["e0005", "ok", "", "0.0042", "0.36", "0.06", "24.1", "1462", "2023-11-14T22:16:20Z", "22"],
    ["e0006", "pending", "", "", "0.40", "0.07", "", "", "", ""],
]
ESTIMATES = [
    ["95.0", "e0003", "10.0", "0.9", "0.085", "0", "0.9"],
    ["100.0", "e0003", "15.0", "0.7", "0.085", "1", "0.7"],
    ["150.0", "e0006", "5.0", "0.01", "0.042", "0", "0.01"],
]


@pytest.fixture
def study(tmp_path, monkeypatch):
    """The analytic example with an evaluations table and calibration.json written by hand."""
    monkeypatch.chdir(tmp_path)
    study = load_study(analytic_example())
    files = study.files
    files.dir.mkdir(parents=True)
    files.calibration.write_text(json.dumps({"started_at": START, "study": study.name}))
    with open(files.evaluations_csv, "w", newline="") as handle:
        csv.writer(handle).writerows([COLUMNS, *ROWS])
    return study


def with_best_and_estimates(study):
    files = study.files
    files.best.write_text(
        json.dumps(
            {
                "evaluation": "e0005",
                "parameters": {"sliding_friction_pp": 0.36, "rolling_friction_pp": 0.06},
            }
        )
    )
    with open(files.early_termination, "w", newline="") as handle:
        csv.writer(handle).writerows([ESTIMATE_COLUMNS, *ESTIMATES])


def pixels(path) -> np.ndarray:
    """The image of a PNG file (height, width, channels); fails on anything but a PNG."""
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG"
    return matplotlib.image.imread(path)


def inked(image: np.ndarray) -> float:
    """The fraction of an image's pixels that are not white."""
    return float((image[..., :3] < 0.95).any(axis=-1).mean())


def test_every_promised_figure_is_written_with_and_without_best_point_and_estimates(
    study, tmp_path
):
    bare = write_plots(study, tmp_path / "bare")  # no best.json, no early_termination.csv
    with_best_and_estimates(study)
    outdir = tmp_path / "figures"
    paths = write_plots(study, outdir)
    assert paths == [outdir / f"{name}.png" for name in FIGURES]
    assert sorted(p.name for p in outdir.iterdir()) == sorted(f"{name}.png" for name in FIGURES)
    for path in [*bare, *paths]:
        assert inked(pixels(path)) > 0.003, f"{path} is (nearly) blank"
    # stacked figures: one panel of 2.2 in (traces) or 2.4 in (responses) per parameter or target
    assert pixels(outdir / "parameter_traces.png").shape[0] == round(2 * 2.2 * 110)
    assert pixels(outdir / "responses_vs_targets.png").shape[0] == round(2 * 2.4 * 110)
    # without estimates, the early-termination figure says so instead of drawing axes and lines
    figure = FIGURES.index("early_termination")
    assert inked(pixels(bare[figure])) < 0.5 * inked(pixels(paths[figure]))


def test_the_table_the_figures_draw_from(study):
    table = load_table(study).set_index("evaluation")
    assert table.loc["e0001", "number"] == 1
    assert table.loc["e0000", "since_start_s"] == pytest.approx(60.0)
    assert table.loc["e0005", "since_start_s"] == pytest.approx(180.0)
    assert np.isnan(table.loc["e0006", "since_start_s"])  # still running
    # CPU time accumulates in the order the evaluations ended: e0000, e0002, e0001, ...
    assert table.loc["e0000", "cpu_total_s"] == pytest.approx(30.0)
    assert table.loc["e0002", "cpu_total_s"] == pytest.approx(55.0)
    assert table.loc["e0001", "cpu_total_s"] == pytest.approx(75.0)
    assert table.loc["e0005", "cpu_total_s"] == pytest.approx(105.0)


def test_a_figure_is_drawn_and_returned_and_written_only_where_asked(study, tmp_path):
    table = load_table(study)
    figure = plot_objective_vs_evaluation(study, table)
    assert isinstance(figure, Figure) and list(tmp_path.rglob("*.png")) == []
    (ax,) = figure.axes
    assert ax.get_yscale() == "log" and "evaluation" in ax.get_xlabel()
    assert len(ax.lines[0].get_xdata()) == 4  # the evaluations with an objective
    buffer = io.BytesIO()
    save_png(figure, buffer)
    path = tmp_path / "history.png"
    assert plot_objective_vs_evaluation(study, table, path).axes
    assert pixels(path).shape == matplotlib.image.imread(io.BytesIO(buffer.getvalue())).shape


def test_the_answers_table_sets_it_against_the_targets(study):
    assert best_point_table(study)["quantity"][0].startswith("no evaluation succeeded")
    best = BestRecord(
        evaluation="e0005",
        parameters={"rolling_friction_pp": 0.06, "sliding_friction_pp": 0.36},
        objective=0.0042,
        predicted_objective=0.004,
        responses={"cylinder_lift.angle_of_repose": 24.1, "cylinder_lift.bulk_density": 1462.0},
        relative_errors={"cylinder_lift.angle_of_repose": -0.036},
        predicted_responses={"cylinder_lift.bulk_density": {"mean": 1460.0, "sd": 3.0}},
        on_bounds={"rolling_friction_pp": "lower"},
    )
    best.write(study.files.best)
    table = answer_table(study, best).set_index("quantity")
    assert list(table.index) == [  # the study's order
        "sliding_friction_pp",
        "rolling_friction_pp",
        "cylinder_lift.angle_of_repose",
        "cylinder_lift.bulk_density",
        "objective",
    ]
    assert table.loc["rolling_friction_pp", "note"] == "on its lower bound"
    assert table.loc["cylinder_lift.bulk_density", "predicted_sd"] == 3.0
    assert table.loc["cylinder_lift.angle_of_repose", "relative_error_percent"] == pytest.approx(
        -3.6
    )
    assert np.isnan(table.loc["cylinder_lift.angle_of_repose", "predicted"])
    assert table.loc["objective", "predicted"] == 0.004
    written = best_point_table(study).set_index("quantity")  # best.csv: empty cells
    assert written.loc["cylinder_lift.angle_of_repose", "predicted"] == ""
