"""The README's two commands stay what CI and users run, and environment.lock pins what they
install."""

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
#: What both commands share: pip takes every version from environment.lock.
INSTALL = "pip install -c environment.lock -e "


def readme_commands():
    return re.findall(r"```bash\n(.+?)\n```", (ROOT / "README.md").read_text())


def setup_commands(commands):
    return [c for c in commands if INSTALL in c]


def lock_pins() -> dict[str, str]:
    """environment.lock as {canonical name: version}; every line pins one package exactly."""
    pins: dict[str, str] = {}
    for line in (ROOT / "environment.lock").read_text().splitlines():
        line = line.split("#")[0].strip()
        if not line:
            continue
        name, version = line.split("==")
        assert canonicalize_name(name) not in pins, f"{name} is pinned twice"
        pins[canonicalize_name(name)] = version
    return pins


def test_readme_gives_exactly_two_setup_commands():
    commands = setup_commands(readme_commands())
    assert len(commands) == 2
    run, test = commands
    # the calibration installs what runs; the test command adds the test extra
    assert f"{INSTALL}. " in run
    assert run.endswith("snakemake --profile profiles/local")
    assert f"{INSTALL}'.[test]' " in test
    assert test.endswith('python -m pytest -q -m "not slow" && python -m pytest -q -m slow')


def test_ci_runs_the_readme_test_command():
    test_command = setup_commands(readme_commands())[1]
    assert test_command in (ROOT / ".ci" / "run").read_text().splitlines()


def test_docs_show_the_readme_commands():
    """The docs' getting-started section gives the same two commands, verbatim."""
    docs = re.findall(r"```bash\n(.+?)\n```", (ROOT / "docs" / "index.md").read_text())
    assert setup_commands(docs) == setup_commands(readme_commands())


def test_the_lock_pins_every_requirement_and_extra():
    """What pyproject.toml asks for is pinned; .ci/run checks the rest of what pip installs."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = [*project["dependencies"]]
    for extra in project["optional-dependencies"].values():
        wanted += extra
    names = {canonicalize_name(Requirement(r).name) for r in wanted} - {"demcal"}
    assert names - set(lock_pins()) == set()
