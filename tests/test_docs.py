"""The documentation builds without a warning, shows every page, and the README's links hold."""

import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: The example notebook (kept without outputs) and its stored run, which the site shows.
NOTEBOOK = DOCS / "example.ipynb"
NOTEBOOK_RUN = DOCS / "example-executed.ipynb"
#: What docstrings written for Sphinx leave on a page that mkdocstrings rendered.
SPHINX_ROLE = re.compile(r":(?:py:)?(?:func|mod|class|meth|attr|data|exc):")
PARAGRAPH_OR_CODE = re.compile(r"<(p|pre)\b[^>]*>(.*?)</\1>", re.S)
REST_RULER = re.compile(r"={4,}")


def mkdocs_config() -> dict:
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text())


def nav_pages(entries) -> set[str]:
    """Every page path in an mkdocs nav (nested sections included)."""
    pages = set()
    for entry in entries:
        if isinstance(entry, str):
            pages.add(entry)
        elif isinstance(entry, dict):
            for value in entry.values():
                pages |= nav_pages(value) if isinstance(value, list) else {value}
    return pages


def notebook_pages(config: dict) -> set[str]:
    """The notebooks that mkdocs-jupyter turns into pages (its ``include`` patterns)."""
    plugin = next(p for p in config["plugins"] if isinstance(p, dict) and "mkdocs-jupyter" in p)
    patterns = plugin["mkdocs-jupyter"]["include"]
    return {
        path.relative_to(DOCS).as_posix()
        for path in DOCS.rglob("*.ipynb")
        if any(path.match(pattern) for pattern in patterns)
    }


def test_every_docs_page_is_in_the_nav():
    config = mkdocs_config()
    pages = {path.relative_to(DOCS).as_posix() for path in DOCS.rglob("*.md")}
    pages |= notebook_pages(config)
    assert NOTEBOOK_RUN.relative_to(DOCS).as_posix() in pages
    listed = nav_pages(config["nav"])
    assert pages - listed == set(), "pages missing from the nav of mkdocs.yml"
    assert listed - pages == set(), "nav entries without a page"


def test_readme_relative_links_point_at_files():
    links = re.findall(r"\]\(([^)\s]+)\)", (ROOT / "README.md").read_text())
    relative = [link for link in links if not re.match(r"[a-z]+:|#", link)]
    assert relative, "the README links to its docs"
    missing = [link for link in relative if not (ROOT / link.split("#")[0]).exists()]
    assert missing == []


def test_the_stored_run_of_the_notebook_is_the_notebook_with_its_outputs():
    """The site shows docs/example-executed.ipynb, a run of docs/example.ipynb. After a change
    of the notebook, make it again:
    jupyter nbconvert --to notebook --execute docs/example.ipynb --output example-executed.ipynb
    """
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    run = nbformat.read(NOTEBOOK_RUN, as_version=4)
    assert [(c.cell_type, c.source) for c in run.cells] == [
        (c.cell_type, c.source) for c in notebook.cells
    ], "docs/example-executed.ipynb is not a run of the current docs/example.ipynb"
    code = [cell for cell in run.cells if cell.cell_type == "code"]
    assert all(cell.execution_count is not None for cell in code), "a cell did not run"
    assert not [o for c in code for o in c.outputs if o.output_type == "error"]
    assert any("image/png" in o.get("data", {}) for c in code for o in c.outputs)


def tutorial_study() -> str:
    """The study file that docs/tutorial.md shows (its first YAML block)."""
    text = (DOCS / "tutorial.md").read_text()
    return re.search(r"```yaml\n(.*?)```", text, re.S).group(1)


@pytest.mark.parametrize("engine", ["lammps", "analytic"])
def test_the_tutorials_study_file_loads_and_converts_its_density(tmp_path, engine):
    from demcal.study.config import load_study_file

    text = tutorial_study()
    assert "  name: lammps\n" in text
    path = tmp_path / "sand-first.yaml"
    path.write_text(text.replace("  name: lammps\n", f"  name: {engine}\n"))
    study = load_study_file(path)
    assert study.name == "sand-first"
    assert [p.name for p in study.free] == ["sliding_friction_pp", "rolling_friction_pp"]
    density = next(t for t in study.targets if t.response == "bulk_density")
    assert (density.value, density.spread) == pytest.approx((1550.0, 20.0))
    assert any("g/cm^3 -> 1550 kg/m^3" in warning for warning in study.warnings)
    assert study.settings["cylinder_lift"]["d50"] == pytest.approx(1.2e-3)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once with ``mkdocs build --strict``."""
    folder = tmp_path_factory.mktemp("docs") / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(folder)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr + proc.stdout
    return folder


@pytest.mark.slow
def test_docs_build_strict(site):
    """Broken links, missing anchors, pages outside the nav and docstrings that
    mkdocstrings cannot render are warnings, which --strict turns into a failure."""
    api_pages = sorted((DOCS / "api").glob("*.md"))
    assert api_pages, "the API reference has pages"
    for page in api_pages:
        html = (site / "api" / page.stem / "index.html").read_text()
        shown = re.findall(r"^::: (\S+)", page.read_text(), re.M)
        assert shown, f"{page.name} renders nothing"
        for name in shown:
            assert f'id="{name}"' in html, f"{page.name} does not render {name}"


@pytest.mark.slow
def test_no_sphinx_roles_or_rest_tables_on_any_page(site):
    """Docstrings are Markdown: a Sphinx role (:func:`x`) or a reStructuredText table
    (its ==== rulers) would be printed as it stands."""
    roles, rulers = {}, {}
    for path in sorted(site.rglob("*.html")):
        page = path.relative_to(site).as_posix()
        html = path.read_text()
        if found := len(SPHINX_ROLE.findall(html)):
            roles[page] = found
        blocks = [body for _, body in PARAGRAPH_OR_CODE.findall(html) if REST_RULER.search(body)]
        if blocks:
            rulers[page] = len(blocks)
    assert roles == {}, "Sphinx roles per page"
    assert rulers == {}, "reST table rulers per page"


@pytest.mark.slow
def test_the_notebook_page_shows_the_outputs_of_its_cells(site):
    html = (site / NOTEBOOK_RUN.stem / "index.html").read_text()
    assert "demcal in a notebook" in html
    # the evaluations as a table
    tables = re.findall(r'<table[^>]*class="dataframe".*?</table>', html, re.S)
    assert any("cylinder_lift.angle_of_repose" in table for table in tables)
    # a figure of the report, as an image
    assert re.search(r'jp-RenderedImage[^>]*>\s*<img [^>]*src="data:image/png;base64,', html)
