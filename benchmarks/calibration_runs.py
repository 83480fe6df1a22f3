"""Whole calibrations of a study, with and without early termination, over several seeds.

    python benchmarks/calibration_runs.py CONFIG [--seeds 1 2 3] [--et on off]
                                          [--workers 2] [--tag TAG]

Each run is ``demcal run`` on a copy of CONFIG with its own study name
(``<study>-et-<on|off>-s<seed>``), optimizer seed and early-termination
switch, in a scratch directory, one run after the other (each with
``--workers`` simulations in flight). Per run it records the wall time, the
CPU time of all simulations (including those stopped early), the number of
evaluations stopped early, the best objective and the best point's responses
against the targets. Prints a markdown table and writes
benchmarks/results/calibration_<study>[_<tag>].json. With synthetic
targets, the best point can be compared with the true one.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]


def run_one(config: dict, study: str, seed: int, et: bool, workers: int, scratch: Path) -> dict:
    variant = {**config, "study": study, "seed": seed,
               "optimizer": {**config.get("optimizer", {}),
                             "early_termination": {"enabled": et}}}
    path = scratch / f"{study}.yaml"
    path.write_text(yaml.safe_dump(variant, sort_keys=False))
    start = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "demcal.cli", "run", str(path), "--workers",
                           str(workers)], cwd=scratch, stdin=subprocess.DEVNULL,
                          capture_output=True, text=True)
    wall = time.monotonic() - start
    results = scratch / "results" / study
    if proc.returncode != 0:
        return {"study": study, "seed": seed, "et": et, "error": proc.stderr[-2000:]}
    evaluations = pd.read_csv(results / "evaluations.csv")
    best = json.loads((results / "best.json").read_text())
    return {"study": study, "seed": seed, "et": et, "wall_s": wall,
            "cpu_s": float(evaluations["cpu_s"].sum()),
            "evaluations": len(evaluations),
            "terminated": int((evaluations["status"] == "terminated").sum()),
            "failed": int((evaluations["status"] == "failed").sum()),
            "best_objective": best["objective"], "best_parameters": best["parameters"],
            "best_responses": best["responses"], "targets": best["targets"]}


def table(runs: list[dict]) -> str:
    lines = ["| ET | seed | evaluations (stopped early) | CPU [s] | wall [s] | best objective "
             "| best point |", "|---|---|---|---|---|---|---|"]
    for r in runs:
        if "error" in r:
            lines.append(f"| {'on' if r['et'] else 'off'} | {r['seed']} | error: "
                         f"{r['error'][-200:]!r} | | | | |")
            continue
        point = ", ".join(f"{k} {v:.3f}" for k, v in sorted(r["best_parameters"].items()))
        lines.append(f"| {'on' if r['et'] else 'off'} | {r['seed']} | {r['evaluations']} "
                     f"({r['terminated']}) | {r['cpu_s']:.0f} | {r['wall_s']:.0f} | "
                     f"{r['best_objective']:.3g} | {point} |")
    for et in (True, False):
        group = [r for r in runs if r["et"] == et and "error" not in r]
        if group:
            lines.append(f"| {'on' if et else 'off'} | mean | | "
                         f"{statistics.fmean(r['cpu_s'] for r in group):.0f} | "
                         f"{statistics.fmean(r['wall_s'] for r in group):.0f} | "
                         f"{statistics.median(r['best_objective'] for r in group):.3g} "
                         f"(median) | |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--et", nargs="+", choices=("on", "off"), default=["on", "off"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--tag", default="")
    args = parser.parse_args()
    config = yaml.safe_load(Path(args.config).read_text())
    name = f"calibration_{config['study']}" + (f"_{args.tag}" if args.tag else "")
    out = ROOT / "benchmarks" / "results" / f"{name}.json"
    runs = []
    with tempfile.TemporaryDirectory() as scratch:
        for seed in args.seeds:
            for et in args.et:
                study = f"{config['study']}-et-{et}-s{seed}"
                run = run_one(config, study, seed, et == "on", args.workers, Path(scratch))
                runs.append(run)
                print(json.dumps(run), flush=True)
                out.write_text(json.dumps({"config": args.config, "runs": runs}, indent=2))
    print()
    print(table(runs))


if __name__ == "__main__":
    main()
