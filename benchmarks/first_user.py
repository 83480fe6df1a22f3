"""A first-time user's frictions (issue 36): the same commands on two checkouts.

Runs the analytic example to its end with the checkout's code, then one probe per
item of the issue (the command line, the Python objects, Snakemake's own dry run and
DAG, the study file's error messages) and writes what each printed: its exit status,
its line count and its first lines. The report's first screen and the docs site are
checked by tests (tests/workflow/test_workflow.py, tests/test_docs.py), not here.

    python benchmarks/first_user.py --root /work/main --label after
    git worktree add --detach /tmp/before be9583a
    python benchmarks/first_user.py --root /tmp/before --label before

Writes benchmarks/results/first_user_<label>.txt.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

HERE = Path(__file__).resolve().parent
EXAMPLE = "config/examples/analytic.yaml"
STUDY = "analytic-demo"
SHOWN_LINES = 6

# Study files with one mistake each (item 8): an example with its lines changed.
LIFT = "config/config.yaml"
MISTAKES = {
    "misspelt section": (EXAMPLE, [("parameters:", "paramters:")]),
    "misspelt option": (EXAMPLE, [("max_evaluations: 30", "max_evaluation: 30")]),
    "convertible unit": (EXAMPLE, [("value: 25.0, unit: deg}", "value: 0.4363, unit: rad}")]),
    "spread in percent": (EXAMPLE, [("unit: deg}", "unit: deg, spread: 3%}")]),
    "target without a unit": (EXAMPLE, [("value: 1450.0, unit: kg/m^3}", "value: 1450.0}")]),
    "youngs_modulus free": (
        LIFT,
        [
            ("  youngs_modulus: 5.0e6", "  # youngs_modulus: 5.0e6"),
            ("upper: 0.3}\n", "upper: 0.3}\n  youngs_modulus: {lower: 5.0e6, upper: 5.0e7}\n"),
        ],
    ),
}

PYTHON_PROBE = """
import demcal
r = demcal.open({study!r})
answer = getattr(r, "answer", None) or r.best
s = r.solutions()
points = s.points()
print("repr of the answer:", len(repr(answer)), "characters;", "of solutions():", len(repr(s)))
print(repr(answer)[:400])
print("points():", type(points).__name__, list(getattr(points, "columns", []))[:3])
print("sensitivity:", type(s.sensitivity).__name__)
print("posterior:", type(s.posterior).__name__, list(getattr(s.posterior, "columns", []))[-2:])
print("figures:", [n for n in dir(r) + dir(s) if n.startswith("plot_")])
"""


def probes(root: Path, fresh: Path) -> dict[str, list[str]]:
    """The commands of each item, run in the study's folder with the checkout's code.

    ``fresh`` is the example under another study name, one that has not run yet.
    """
    demcal = [sys.executable, "-m", "demcal.cli"]
    config = str(root / EXAMPLE)
    snakemake = [
        "snakemake",
        "-s",
        str(root / "Snakefile"),
        "--profile",
        str(root / "profiles/local"),
    ]
    return {
        "3 report": [*demcal, "report", STUDY],
        "4 version": [*demcal, "--version"],
        "4 check": [*demcal, "check", config],
        "4 convergence by name": [*demcal, "convergence", STUDY, "--scene", "no_such_scene"],
        "4 --point before the study": [
            *demcal,
            "solutions",
            "--point",
            "sliding_friction_pp=0.3",
            "rolling_friction_pp=0.1",
            STUDY,
        ],
        "4 archive list --study": [*demcal, "archive", "list", "--study", "my-beads"],
        "4 workers on convergence": [*demcal, "convergence", "--help"],
        "5 python objects": [sys.executable, "-c", PYTHON_PROBE.format(study=STUDY)],
        "6 dry run": [*snakemake, f"--configfile={fresh}", "-n"],
        "6 dag": [*snakemake, f"--configfile={fresh}", "--dag"],
    }


def run(command: list[str], cwd: Path, root: Path, timeout: float = 600.0) -> tuple[int, list[str]]:
    """Exit status and output lines of one command with ROOT's demcal first on the path."""
    env = {**os.environ, "PYTHONPATH": str(root), "MPLBACKEND": "Agg"}
    with subprocess.Popen(
        command,
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    ) as child:
        try:
            output, _ = child.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)  # with the Snakemake it started
            output, _ = child.communicate()
            return -1, [f"(still running after {timeout:.0f} s: accepted)", *output.splitlines()]
    return child.returncode, output.splitlines()


def shown(status: int, lines: list[str], keep: int = SHOWN_LINES) -> str:
    """One probe's record: status, line count, the first lines (tracebacks flagged)."""
    traceback = any(line.startswith("Traceback") for line in lines)
    head = "\n".join(line[:160] for line in lines[:keep])
    flag = ", TRACEBACK" if traceback else ""
    return f"exit {status}, {len(lines)} lines{flag}\n{textwrap.indent(head, '    ')}\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, required=True, help="the checkout whose code runs")
    parser.add_argument("--label", required=True, help="names the results file")
    args = parser.parse_args()
    root = args.root.resolve()
    out: list[str] = [f"# first_user.py --root {root} ({args.label})\n"]
    with tempfile.TemporaryDirectory(prefix="first_user_") as folder:
        work = Path(folder)
        shutil.copytree(root / "config", work / "config")
        status, lines = run([sys.executable, "-m", "demcal.cli", "run", EXAMPLE], work, root, 1800)
        progress = [line for line in lines if "best" in line.lower() or "answer" in line.lower()]
        out.append("## 2 demcal run config/examples/analytic.yaml: lines naming best or answer")
        out.append(shown(status, progress, keep=40))
        out.append("## 3 the run's last lines")
        out.append(shown(status, lines[-8:], keep=8))
        fresh = work / "config" / "fresh.yaml"
        fresh.write_text((root / EXAMPLE).read_text().replace(f"study: {STUDY}", "study: fresh"))
        for name, command in probes(root, fresh).items():
            status, lines = run(command, work, root, 120)
            if name == "4 workers on convergence":
                lines = [line for line in lines if "--jobs" in line or "--workers" in line]
            if name == "6 dag":
                simulate = sum("simulate" in line for line in lines)
                lines = [f"nodes naming simulate: {simulate}", *lines]
            out.append(f"## {name}: {' '.join(command[2:] if command[1] == '-m' else command)}")
            out.append(
                shown(status, lines, keep=30 if name.startswith(("5", "6 dry")) else SHOWN_LINES)
            )
        for name, (example, changes) in MISTAKES.items():
            study = work / "config" / f"mistake_{name.replace(' ', '_')}.yaml"
            text = (root / example).read_text()
            for old, new in changes:
                text = text.replace(old, new)
            study.write_text(text)
            status, lines = run(
                [sys.executable, "-m", "demcal.cli", "check", str(study)], work, root, 120
            )
            if status == 2 and any("invalid choice" in line for line in lines):  # no `check` yet
                status, lines = run(
                    [sys.executable, "-m", "demcal.cli", "run", str(study)], work, root, 30
                )
            out.append(f"## 8 {name}: {example} with {changes!r}")
            out.append(shown(status, lines))
    target = HERE / "results" / f"first_user_{args.label}.txt"
    target.write_text("\n".join(out))
    print(target)


if __name__ == "__main__":
    main()
