"""The report's headline (reStructuredText) from a finished study's files."""

from __future__ import annotations

import base64
import json

import docutils.core
import docutils.nodes
import docutils.utils
import pytest
from helpers import analytic_example, read_objective, run_in_process

from demcal.reporting.headline import report_headline
from demcal.results.storage import write_json
from demcal.study.config import load_study
from demcal.study.model import freeze

ANGLE, DENSITY = "cylinder_lift.angle_of_repose", "cylinder_lift.bulk_density"
FAILING = {"when": {"sliding_friction_pp": [0.14, 0.16]}, "reason": "injected for the test"}


@pytest.fixture
def study(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = analytic_example(
        optimizer={"response_model": "cubic_rbf"}, engine={"failures": [FAILING]}
    )
    return freeze(load_study(config))


def rst_problems(text: str) -> list[str]:
    """Warnings and errors docutils finds in a reStructuredText document."""
    document = docutils.core.publish_doctree(
        text, settings_overrides={"report_level": docutils.utils.Reporter.SEVERE_LEVEL + 1}
    )
    return [
        node.astext()
        for node in document.findall(docutils.nodes.system_message)
        if node["level"] >= docutils.utils.Reporter.WARNING_LEVEL
    ]


def table_row(cells: list[str]) -> str:
    """A row of a list-table as the headline writes it."""
    return "\n".join([f"   * - {cells[0]}", *(f"     - {cell}" for cell in cells[1:])])


def test_headline_of_a_finished_calibration(study):
    run_in_process(study, 5, extra_points=[[0.15, 0.1]])
    best = json.loads(study.files.best.read_text())
    headline = report_headline(study)

    assert headline.startswith("The answer\n==========\n")
    assert "**Ended:** evaluation budget spent. **Evaluations:** 6 (5 ok, 1 failed, 0 stopped" in (
        headline
    )
    assert "simulation CPU time" in headline
    assert f"(evaluation ``{best['evaluation']}``, the evaluated point with the lowest " in (
        headline
    )
    value = best["parameters"]["sliding_friction_pp"]
    assert table_row(["sliding_friction_pp", f"{value:.4g}", "0.1 – 0.9"]) in headline
    simulated = read_objective(study.files.evaluation(best["evaluation"]))["responses"][ANGLE]
    predicted = best["predicted_responses"][ANGLE]
    error = 100 * (simulated - 25.0) / 25.0
    assert (
        table_row(
            [
                f"{ANGLE} [deg]",
                f"{simulated:.4g}",
                f"{predicted['mean']:.4g} ±{predicted['sd']:.2g}",
                "25",
                f"{error:+.1f}%",
            ]
        )
        in headline
    )
    assert "Confirmed" not in headline and "What the targets identify" not in headline
    assert "is not measured" not in headline  # two replicates per evaluation measure it
    assert rst_problems(headline) == []


def test_headline_says_when_the_scatter_of_single_runs_is_not_measured(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(analytic_example(replicates=1)))
    write_json(study.files.finished, {"reason": "answer known", "evaluations": {"ok": 4}})
    write_json(
        study.files.best,
        {
            "evaluation": "e0003",
            "objective": 0.001,
            "parameters": {"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.1},
            "responses": {ANGLE: 25.5, DENSITY: 1430.0},
            "predicted_responses": {ANGLE: {"mean": 25.4, "sd": 0.001}},
        },
    )
    headline = report_headline(study)
    assert (
        "No point was simulated twice, so the scatter of single simulations is not measured "
        "and the predicted sd may be too small: set ``optimizer.confirm_replicates``"
    ) in " ".join(headline.split())
    assert rst_problems(headline) == []


def test_headline_before_the_calibration_has_finished(study):
    assert report_headline(study) == (
        "The answer\n==========\n\n"
        "The calibration has not finished (no finished.json): run it first.\n"
    )


def test_headline_when_no_evaluation_succeeded(study):
    counts = {"failed": 3}
    write_json(study.files.finished, {"reason": "evaluation budget spent", "evaluations": counts})
    headline = report_headline(study)
    assert "**Evaluations:** 3 (0 ok, 3 failed, 0 stopped early)." in headline
    assert headline.endswith("No evaluation succeeded: the reasons are in ``evaluations.csv``.\n")
    assert rst_problems(headline) == []


def test_headline_from_files_written_by_hand(study):
    files = study.files
    write_json(
        files.finished,
        {"reason": "target objective reached", "evaluations": {"ok": 7, "terminated": 2}},
    )
    write_json(
        files.best,
        {
            "evaluation": "e0006",
            "objective": 0.0006,
            "chosen_by": "objective surrogate",
            "parameters": {"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.3},
            "on_bounds": {"rolling_friction_pp": "upper"},
            "responses": {ANGLE: 25.5, DENSITY: 1430.0},
            "relative_errors": {ANGLE: 0.02, DENSITY: -20.0 / 1450.0},
            "confirmation": {
                "of": "e0006",
                "evaluations": ["e0008", "e0009"],
                "pending": 0,
                "failed": 0,
                "responses": {ANGLE: {"mean": 25.25, "sd": 0.35, "count": 2}},
            },
        },
    )
    write_json(
        files.solutions_summary,
        {
            "likely": 12,
            "possible": 30,
            "sampled": 4000,
            "k": 2.0,
            "verdicts": [{"sentence": "sliding_friction_pp is identified."}],
            "posterior": {
                "interval_90": {"sliding_friction_pp": [0.31, 0.42]},
                "effective_samples": 812.4,
            },
        },
    )
    image = b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 2
    files.plots.mkdir(parents=True)
    (files.plots / "solution_space.png").write_bytes(image)

    headline = report_headline(study)
    assert "**Ended:** target objective reached. **Evaluations:** 9 (7 ok, 0 failed, 2 stopped" in (
        headline
    )
    assert "CPU time" not in headline  # no evaluations.csv to add it up from
    assert "lowest of observed and surrogate-predicted objective" in headline
    assert table_row(["rolling_friction_pp", "0.3", "0.02 – 0.3 **on its upper bound**"]) in (
        headline
    )
    assert table_row([f"{DENSITY} [kg/m^3]", "1430", "–", "1450", "-1.4%"]) in headline
    assert "**Confirmed** by 2 more simulations of the best point" in headline
    assert table_row([ANGLE, "25.25 ±0.35", "2", "25"]) in headline
    assert "scatter of single simulations is not" not in headline  # the confirmations measure it
    assert (
        "(12 of 4000 sampled parameter sets are likely to meet every target within 2 sd, "
        "30 cannot be ruled out)" in headline
    )
    assert "- sliding_friction_pp is identified." in headline
    assert "812 effective samples), central 90 %: sliding_friction_pp 0.31–0.42" in headline
    # the figure is embedded: its bytes are in the data URI, cut into lines
    lines = headline.splitlines()
    start = lines.index(".. image::") + 1
    end = lines.index("   :width: 100%")
    uri = "".join(line.strip() for line in lines[start:end])
    assert uri.startswith("data:image/png;base64,")
    assert base64.b64decode(uri.removeprefix("data:image/png;base64,")) == image
    assert max(map(len, lines)) < 10000  # docutils' limit on a line
    assert "sensitivity.png" not in headline and headline.count(".. image::") == 1
    assert rst_problems(headline) == []
