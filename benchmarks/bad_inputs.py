"""How each route handles the bad-input corpus: counts of clean refusals, tracebacks, silence.

    python benchmarks/bad_inputs.py                   # this checkout
    python benchmarks/bad_inputs.py --root /tmp/old   # another checkout: its demcal,
                                                      # Snakefile and profiles

Every study file of tests/bad_inputs.py goes through ``demcal run`` and the
README's ``snakemake --profile profiles/<local|slurm> --configfile=FILE``;
the command lines of tests/bad_commands.py through ``demcal ...`` (archive, reuse,
campaigns, metamodels, psd fit, solutions), as the route "demcal commands"; the
hand-written points through ``snakemake --profile profiles/local
results/.../objective.json``. Verdicts (tests/bad_inputs.py, Outcome.verdict):
clean (one line, naming what tests/bad_inputs.py expects), other message
(one demcal line, other words), several lines, traceback, silent, wrongly
accepted (exit 0 or a simulation started), timed out (after
tests/bad_inputs.py's ROUTE_TIMEOUT), wrote outside results/.
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from bad_commands import gathered_cases, run_command  # noqa: E402
from bad_inputs import CASES, POINTS, ROOT, ROUTES, route_command, run_route, write_point  # noqa: E402

#: The route of tests/bad_commands.py's cases: demcal's other commands.
COMMANDS_ROUTE = "demcal commands"


def point_verdict(root: Path, point, folder: Path, env: dict) -> str:
    """The README's "evaluate your own point" with a bad params.json: failed with
    its reason, exit 0."""
    folder.mkdir(parents=True)
    study, target = write_point(folder, point)
    done = subprocess.run(
        route_command("snakemake local", study, root, target),
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    output = done.stdout + done.stderr
    if "Traceback" in output or "Error in file" in output:
        return "traceback"
    reasons = [line for line in output.splitlines() if line.startswith("  reason: ")]
    if done.returncode != 0:
        return "silent" if not reasons else "several lines"
    return "clean" if reasons and re.search(point.reason, reasons[0]) else "other message"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT, help="checkout whose code is run")
    args = parser.parse_args()
    root = args.root.resolve()
    env = {**os.environ, "PYTHONPATH": str(root)}  # that checkout's demcal before the installed one
    counts = {route: collections.Counter() for route in (*ROUTES, "params.json", COMMANDS_ROUTE)}
    misses = []
    with tempfile.TemporaryDirectory() as scratch, ThreadPoolExecutor(2) as pool:
        jobs = {
            (route, case.name): pool.submit(
                run_route,
                route,
                case,
                Path(scratch) / case.name / route.replace(" ", "_"),
                root,
                env,
            )
            for case in CASES
            for route in ROUTES
        }
        points = {
            point.name: pool.submit(point_verdict, root, point, Path(scratch) / point.name, env)
            for point in POINTS
        }
        for (route, name), job in jobs.items():
            case = next(c for c in CASES if c.name == name)
            verdict = job.result().verdict(case.message)
            counts[route][verdict] += 1
            if verdict != "clean":
                misses.append(
                    f"{route:16s} {name:28s} {verdict}: {' | '.join(job.result().lines)[:160]}"
                )
        for job in points.values():
            counts["params.json"][job.result()] += 1
    commands = gathered_cases()
    with tempfile.TemporaryDirectory() as scratch:  # one at a time: some measure their memory
        for case in commands:
            outcome = run_command(case, Path(scratch) / case.name, root)
            verdict = outcome.verdict(case)
            counts[COMMANDS_ROUTE][verdict] += 1
            if verdict != "clean":
                shown = " | ".join(outcome.lines[-3:])[:160]
                misses.append(f"{COMMANDS_ROUTE:16s} {case.name:28s} {verdict}: {shown}")
    verdicts = sorted({v for c in counts.values() for v in c})
    print(
        f"{len(CASES)} study files, {len(POINTS)} hand-written points, {len(commands)} "
        f"command lines; code of {root}"
    )
    print(f"{'route':18s}" + "".join(f"{v:>18s}" for v in verdicts))
    for route, count in counts.items():
        print(f"{route:18s}" + "".join(f"{count[v]:>18d}" for v in verdicts))
    print("\nnot clean:")
    print("\n".join(misses) or "  none")


if __name__ == "__main__":
    main()
