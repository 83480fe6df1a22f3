"""The bad-input corpus of demcal's other commands: archive, reuse, campaigns, metamodels,
``psd fit``, ``solutions`` and the Python API.

A case is one ``demcal ...`` command line run in a folder that ``prepare`` fills (a study
file, a finished calibration, a damaged archive, a huge file). It must end as its
``outcome`` says:

- ``refused``: a non-zero exit and one line, starting ``demcal: ``, that matches
  ``message``;
- ``warned``: exit 0, a line that matches ``message`` (the bad part named and skipped),
  and the command carried on.

Neither may print a traceback or run past ``timeout`` seconds. The cases of each area live in
their own module (``bad_commands_*.py``, a list ``CASES``) and are gathered by
:func:`gathered_cases`;
tests/test_bad_inputs.py runs each, and ``benchmarks/bad_inputs.py`` counts the verdicts as
the route "demcal commands".
"""

from __future__ import annotations

import copy
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import yaml
from helpers import ANALYTIC_STUDY

#: Where a finished tiny calibration is kept once per process (``finished_study``).
STUDY_FILE = "study.yaml"
#: A small analytic study: five evaluations, one replicate, no noise.
SMALL_STUDY = {
    **copy.deepcopy(ANALYTIC_STUDY),
    "study": "small",
    "replicates": 1,
    "optimizer": {"max_evaluations": 5, "response_model": "cubic_rbf", "map_solutions": 0},
}


def write_study(folder: Path, config: dict | None = None, name: str = STUDY_FILE) -> Path:
    """Write ``config`` (default :data:`SMALL_STUDY`) as a study file in ``folder``."""
    path = folder / name
    path.write_text(yaml.safe_dump(config or SMALL_STUDY, sort_keys=False))
    return path


#: The checkout whose demcal the cases run (None: the installed one); set by run_command, so
#: that a finished study is made by the demcal that reads it (its archive's schema).
_root: Path | None = None


def demcal_env(root: Path | None) -> dict | None:
    """The environment that runs ``root``'s demcal (None: this one's)."""
    return None if root is None else {**os.environ, "PYTHONPATH": str(root)}


@cache
def _finished_template(root: Path | None) -> Path:
    """A folder holding the small study, run to its end once by ``root``'s demcal (its
    results and archive)."""
    folder = Path(tempfile.mkdtemp(prefix="demcal-finished-"))
    write_study(folder)
    done = subprocess.run(
        [sys.executable, "-m", "demcal.cli", "run", STUDY_FILE, "--workers", "2"],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=600,
        stdin=subprocess.DEVNULL,
        env=demcal_env(root),
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return folder


def finished_study(folder: Path) -> None:
    """Copy the finished small study (study file, results/, archive) into ``folder``."""
    shutil.copytree(_finished_template(_root), folder, dirs_exist_ok=True)


@dataclass(frozen=True)
class BadCommand:
    """One bad use of a command and how it must end."""

    name: str
    argv: tuple[str, ...]  # the words after ``demcal``
    message: str  # regular expression the refusal or warning line must match
    prepare: Callable[[Path], None] | None = None
    outcome: str = "refused"  # refused | warned
    timeout: float = 60.0


@dataclass(frozen=True)
class CommandOutcome:
    returncode: int | None  # None: timed out
    lines: list[str]

    def verdict(self, case: BadCommand) -> str:
        """clean, or how the command fell short of ``case``'s outcome."""
        text = "\n".join(self.lines)
        if self.returncode is None:
            return "timed out"
        if "Traceback" in text:
            return "traceback"
        if case.outcome == "warned":
            if self.returncode != 0:
                return "refused instead of warned"
            return "clean" if re.search(case.message, text) else "silent"
        if self.returncode == 0:
            return "wrongly accepted"
        if not self.lines:
            return "silent"
        if len(self.lines) > 1 or not self.lines[0].startswith("demcal: "):
            return "several lines"
        return "clean" if re.search(case.message, self.lines[0]) else "other message"


def run_command(case: BadCommand, folder: Path, root: Path | None = None) -> CommandOutcome:
    """Prepare ``folder`` and run ``case`` there (with ``root``'s demcal if given)."""
    global _root
    _root = root
    folder.mkdir(parents=True, exist_ok=True)
    if case.prepare is not None:
        case.prepare(folder)
    try:
        done = subprocess.run(
            [sys.executable, "-m", "demcal.cli", *case.argv],
            cwd=folder,
            capture_output=True,
            stdin=subprocess.DEVNULL,
            timeout=case.timeout,
            env=demcal_env(root),
        )
        returncode, output = done.returncode, done.stdout + done.stderr
    except subprocess.TimeoutExpired as exc:
        returncode, output = None, (exc.stdout or b"") + (exc.stderr or b"")
    lines = [line for line in output.decode(errors="replace").splitlines() if line.strip()]
    return CommandOutcome(returncode, lines)


def gathered_cases() -> list[BadCommand]:
    """The cases of every ``bad_commands_*.py`` beside this file, in name order."""
    import importlib

    cases: list[BadCommand] = []
    for path in sorted(Path(__file__).parent.glob("bad_commands_*.py")):
        cases.extend(importlib.import_module(path.stem).CASES)
    return cases
