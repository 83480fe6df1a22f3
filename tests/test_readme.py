"""The README's two commands stay what CI and users run."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def readme_commands():
    return re.findall(r"```bash\n(.+?)\n```", (ROOT / "README.md").read_text())


def test_readme_gives_exactly_two_setup_commands():
    commands = [c for c in readme_commands() if "pip install -r environment.lock" in c]
    assert len(commands) == 2
    assert commands[0].endswith("snakemake --profile profiles/local")
    assert commands[1].endswith("python -m pytest -q")


def test_ci_runs_the_readme_test_command():
    test_command = [c for c in readme_commands() if c.endswith("python -m pytest -q")][0]
    assert test_command in (ROOT / ".ci" / "run").read_text().splitlines()


def test_docs_show_the_readme_commands():
    """The docs' getting-started section gives the same two commands, verbatim."""
    setup = [c for c in readme_commands() if "pip install -r environment.lock" in c]
    docs = re.findall(r"```bash\n(.+?)\n```", (ROOT / "docs" / "index.md").read_text())
    assert [c for c in docs if "pip install -r environment.lock" in c] == setup
