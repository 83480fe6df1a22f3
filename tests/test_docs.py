"""The documentation builds without a warning, shows every page, and the README's links hold."""

import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


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


def test_every_docs_page_is_in_the_nav():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    pages = {path.relative_to(DOCS).as_posix() for path in DOCS.rglob("*.md")}
    listed = nav_pages(config["nav"])
    assert pages - listed == set(), "pages missing from the nav of mkdocs.yml"
    assert listed - pages == set(), "nav entries without a page"


def test_readme_relative_links_point_at_files():
    links = re.findall(r"\]\(([^)\s]+)\)", (ROOT / "README.md").read_text())
    relative = [link for link in links if not re.match(r"[a-z]+:|#", link)]
    assert relative, "the README links to its docs"
    missing = [link for link in relative if not (ROOT / link.split("#")[0]).exists()]
    assert missing == []


@pytest.mark.slow
def test_docs_build_strict(tmp_path):
    """Broken links, missing anchors, pages outside the nav and docstrings that
    mkdocstrings cannot render are warnings, which --strict turns into a failure."""
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr + proc.stdout
    api_pages = sorted((DOCS / "api").glob("*.md"))
    assert api_pages, "the API reference has pages"
    for page in api_pages:
        html = (tmp_path / "site" / "api" / page.stem / "index.html").read_text()
        assert f'id="demcal.{page.stem}"' in html, f"{page.name} does not render demcal.{page.stem}"
