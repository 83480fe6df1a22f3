"""The example notebook (docs/example.ipynb) runs from top to bottom and shows the answer,
the figures and the solution space."""

from __future__ import annotations

import math
import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "docs" / "example.ipynb"


def text_of(cell) -> str:
    """Everything a code cell printed or showed as text (streams and plain reprs)."""
    parts = []
    for output in cell.outputs:
        if output.output_type == "stream":
            parts.append(output.text)
        elif "data" in output:
            parts.append(output.data.get("text/plain", ""))
    return "\n".join(parts)


def cell_with(source: str, cells):
    """The one code cell whose source holds ``source``."""
    (cell,) = [cell for cell in cells if source in cell.source]
    return cell


def html_of(cell) -> str:
    """The HTML a code cell showed (a DataFrame's table)."""
    return next(o.data["text/html"] for o in cell.outputs if "text/html" in o.get("data", {}))


@pytest.mark.slow
def test_the_example_notebook_calibrates_and_shows_the_results(tmp_path):
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not cell.get("outputs") for cell in notebook.cells if cell.cell_type == "code")
    # the parameters cell names the example relative to docs/ and a fresh temporary folder;
    # here: the example of this checkout, and tmp_path (as papermill injects parameters)
    tagged = [i for i, c in enumerate(notebook.cells) if "parameters" in c.metadata.get("tags", [])]
    assert len(tagged) == 1
    example = ROOT / "config" / "examples" / "analytic.yaml"
    notebook.cells.insert(
        tagged[0] + 1,
        nbformat.v4.new_code_cell(
            f"example = Path({str(example)!r})\nworkdir = Path({str(tmp_path)!r})"
        ),
    )
    NotebookClient(
        notebook,
        timeout=900,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    ).execute()
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    budget = int(re.search(r"^budget = (\d+)$", code[0].source, re.M).group(1))
    everything = "\n".join(text_of(cell) for cell in code)

    assert "'analytic-notebook'" in everything and "2 free parameters, 2 targets" in everything
    assert f"finished: evaluation budget reached ({budget} of {budget})" in everything
    assert f"{budget} evaluations, {budget} ok" in everything
    table = cell_with("table.rename", code)
    html = html_of(table)
    assert html.split("<tbody>")[1].count("<tr>") == budget  # one row per evaluation
    assert "cylinder_lift.angle_of_repose [deg]" in html and "started_at [UTC]" in html
    # the answer: its repr names the evaluation, the parameters with units, the objective
    answer = text_of(cell_with("answer = results.answer", code))
    assert re.search(r"answer of 'analytic-notebook': evaluation e\d{4} ", answer)
    objective = float(re.search(r"([\d.e+-]+) observed in its own runs", answer).group(1))
    assert math.isfinite(objective) and objective >= 0
    assert re.search(r"sliding_friction_pp = [\d.e+-]+ \[-\]", answer)
    assert len(answer.splitlines()) <= 5
    assert "kg/m^3" in html_of(cell_with("answer.to_frame()", code))
    # every figure is shown once, as PNG, and draw_figures writes the report's files
    for cell in (c for c in code if ".plot_" in c.source):
        shown = [o for o in cell.outputs if "image/png" in o.get("data", {})]
        assert len(shown) == 1, cell.source
    assert "'objective_vs_evaluation'" in text_of(cell_with("draw_figures", code))
    assert (tmp_path / "results/analytic-notebook/plots/objective_vs_evaluation.png").is_file()
    # the solution space: a verdict per parameter, the sensitivities, the weighted posterior
    assert re.search(
        r"sliding_friction_pp: (pinned|partly identified|not identified|not established)",
        text_of(cell_with("verdict.sentence", code)),
    )
    assert "cylinder_lift.bulk_density" in html_of(cell_with("solutions.sensitivity", code))
    posterior = cell_with("solutions.posterior", code)
    assert re.search(r"\d+ effective samples", text_of(posterior))
    assert "sliding_friction_pp [-]" in html_of(posterior) and "weight" in html_of(posterior)
