"""The example notebook (docs/example.ipynb) runs from top to bottom and shows the answer."""

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


@pytest.mark.slow
def test_the_example_notebook_calibrates_and_shows_table_best_point_and_figure(tmp_path):
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
    outputs = [text_of(cell) for cell in code]
    everything = "\n".join(outputs)

    assert "'analytic-notebook'" in everything and "2 free parameters, 2 targets" in everything
    assert f"finished: evaluation budget reached ({budget} of {budget})" in everything
    assert f"{budget} evaluations, {budget} ok" in everything
    table = next(cell for cell in code if "table.rename" in cell.source)
    html = next(o.data["text/html"] for o in table.outputs if "data" in o)
    assert html.split("<tbody>")[1].count("<tr>") == budget  # one row per evaluation
    assert "cylinder_lift.angle_of_repose [deg]" in html and "started_at [UTC]" in html
    objective = float(re.search(r"best point: e\d{4}, objective (\S+) ", everything).group(1))
    assert math.isfinite(objective) and objective >= 0
    assert re.search(r"sliding_friction_pp = [\d.e+-]+ -", everything)
    figure = next(cell for cell in code if "draw_figures" in cell.source)
    assert any("image/png" in o.get("data", {}) for o in figure.outputs)
    assert (tmp_path / "results/analytic-notebook/plots/objective_vs_evaluation.png").is_file()
    assert re.search(
        r"sliding_friction_pp: (pinned|partly identified|not identified|not established)",
        outputs[-1],
    )
