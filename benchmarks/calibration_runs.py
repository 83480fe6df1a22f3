"""Whole calibrations of a study, with and without early termination, over seeds and strategies.

    python benchmarks/calibration_runs.py CONFIG [--seeds 1 2 3] [--et on off]
                                          [--workers 2] [--strategies NAME ...]
                                          [--replicates N] [--tag TAG] [--keep DIR]

``--et``: ``on`` (demcal's default rule, weighed), ``eq_3_4`` (the thesis' rule
alone) or ``off``, each a run per seed. ``--replicates`` overrides the config's
replicates (the study's staging stays ``auto``: staged when early termination is on).

Each run is ``demcal run`` on a copy of CONFIG with its own study name
(``<study>-et-<on|off>-s<seed>``, or ``<study>-<strategy>-et-<on|off>-s<seed>``
with ``--strategies``), optimizer seed, early-termination switch and, with
``--strategies``, ``optimizer.strategy`` (without it: the config's own), in a
scratch directory, one run after the other (each with ``--workers``
simulations in flight). Per run it records the wall time, the CPU time of
all simulations (including those stopped early), the number of evaluations
stopped early, the best objective and the best point's responses against the
targets, and each evaluation's status, point, responses, objective and the
running best objective (lowest observed so far, in evaluation order). Where
every target has a spread, the noise level is the objective of responses one
spread off each target (relative form, eq. 3.3: sum of w (spread / value)^2;
precision form: sum of w), and the run records after how many simulations
(stopped ones included) the running best first fell below it. Prints a markdown table
and writes benchmarks/results/calibration_<study>[_<tag>].json. With
synthetic targets, the best point can be compared with the true one.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import yaml

from demcal.study.model import Study, load_frozen

ROOT = Path(__file__).resolve().parents[1]


def noise_level(study: Study) -> float | None:
    """The study's objective of responses one spread off every target (in its own form: the
    precision form gives the sum of the weights); None if a target has no spread."""
    if any(t.spread is None for t in study.targets):
        return None
    return float(study.objective.of_means({t.key: t.missed_by(t.spread) for t in study.targets}))


def trace(evaluations: pd.DataFrame, config: dict, study: Study) -> dict:
    """Per evaluation (in evaluation order): status, point, responses, objective, running best.

    Also the noise level and the simulations until the running best first fell below it.
    """
    noise = noise_level(study)
    names = list(config["parameters"])
    keys = [f"{t['scene']}.{t['response']}" for t in config["targets"]]
    evaluations = evaluations.sort_values("evaluation")
    best, rows, to_noise = math.inf, [], None
    for n, (_, row) in enumerate(evaluations.iterrows(), 1):
        ok = row["status"] == "ok" and pd.notna(row["objective"])
        objective = float(row["objective"]) if ok else None
        if objective is not None:
            best = min(best, objective)
        if to_noise is None and noise is not None and best < noise:
            to_noise = n
        rows.append(
            {
                "evaluation": row["evaluation"],
                "status": row["status"],
                "parameters": {k: float(row[k]) for k in names if k in row},
                "responses": {k: float(row[k]) for k in keys if k in row and pd.notna(row[k])},
                "objective": objective,
                "running_best": best if math.isfinite(best) else None,
            }
        )
    return {"noise_level": noise, "simulations_to_noise": to_noise, "trace": rows}


def run_one(
    config: dict, study: str, seed: int, et: str, strategy: str | None, workers: int, scratch: Path
) -> dict:
    """One calibration; ``et``: on (the default rule), eq_3_4 or off."""
    termination = {"enabled": et != "off", **({"rule": et} if et == "eq_3_4" else {})}
    optimizer = {**config.get("optimizer", {}), "early_termination": termination}
    if strategy is not None:
        optimizer["strategy"] = strategy
    strategy = optimizer.get("strategy", "(default)")
    variant = {**config, "study": study, "seed": seed, "optimizer": optimizer}
    path = scratch / f"{study}.yaml"
    path.write_text(yaml.safe_dump(variant, sort_keys=False))
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, "-m", "demcal.cli", "run", str(path), "--workers", str(workers)],
        cwd=scratch,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
    )
    wall = time.monotonic() - start
    results = scratch / "results" / study
    if proc.returncode != 0:
        return {
            "study": study,
            "strategy": strategy,
            "seed": seed,
            "et": et,
            "error": proc.stderr[-2000:],
        }
    evaluations = pd.read_csv(results / "evaluations.csv")
    best = json.loads((results / "best.json").read_text())
    return {
        "study": study,
        "strategy": strategy,
        "seed": seed,
        "et": et,
        "wall_s": wall,
        "cpu_s": float(evaluations["cpu_s"].sum()),
        "evaluations": len(evaluations),
        "terminated": int((evaluations["status"] == "terminated").sum()),
        "failed": int((evaluations["status"] == "failed").sum()),
        "best_objective": best["objective"],
        "best_parameters": best["parameters"],
        "best_responses": best["responses"],
        "targets": best["targets"],
        **trace(evaluations, config, load_frozen(results / "study.json")),
    }


def table(runs: list[dict]) -> str:
    lines = [
        "| strategy | ET | seed | evaluations (stopped early) | CPU [s] | wall [s] "
        "| best objective | simulations to noise level | best point |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        if "error" in r:
            lines.append(
                f"| {r['strategy']} | {r['et']} | {r['seed']} | "
                f"error: {r['error'][-200:]!r} | | | | | |"
            )
            continue
        point = ", ".join(f"{k} {v:.3f}" for k, v in sorted(r["best_parameters"].items()))
        to_noise = r["simulations_to_noise"] or "never"
        lines.append(
            f"| {r['strategy']} | {r['et']} | {r['seed']} | "
            f"{r['evaluations']} ({r['terminated']}) | {r['cpu_s']:.0f} | "
            f"{r['wall_s']:.0f} | {r['best_objective']:.3g} | {to_noise} | {point} |"
        )
    for strategy in dict.fromkeys(r["strategy"] for r in runs):
        for et in dict.fromkeys(r["et"] for r in runs):
            group = [
                r for r in runs if r["strategy"] == strategy and r["et"] == et and "error" not in r
            ]
            if group:
                lines.append(
                    f"| {strategy} | {et} | mean | | "
                    f"{statistics.fmean(r['cpu_s'] for r in group):.0f} | "
                    f"{statistics.fmean(r['wall_s'] for r in group):.0f} | "
                    f"{statistics.median(r['best_objective'] for r in group):.3g} "
                    f"(median) | | |"
                )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--et", nargs="+", choices=("on", "eq_3_4", "off"), default=["on", "off"])
    parser.add_argument("--replicates", type=int, default=None)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--strategies",
        nargs="+",
        default=None,
        help="optimizer.strategy of each run (default: the config's own)",
    )
    parser.add_argument("--tag", default="")
    parser.add_argument(
        "--keep",
        type=Path,
        default=None,
        help="run the calibrations in this folder and keep it (default: a scratch folder)",
    )
    args = parser.parse_args()
    config = yaml.safe_load(Path(args.config).read_text())
    if args.replicates is not None:
        config["replicates"] = args.replicates
    name = f"calibration_{config['study']}" + (f"_{args.tag}" if args.tag else "")
    out = ROOT / "benchmarks" / "results" / f"{name}.json"
    runs = []
    with tempfile.TemporaryDirectory() as scratch:
        if args.keep is not None:
            args.keep.mkdir(parents=True, exist_ok=True)
            scratch = str(args.keep)
        for seed in args.seeds:
            for et in args.et:
                for strategy in args.strategies or [None]:
                    prefix = config["study"] + (f"-{strategy}" if strategy else "")
                    study = f"{prefix}-et-{et}-s{seed}"
                    run = run_one(config, study, seed, et, strategy, args.workers, Path(scratch))
                    runs.append(run)
                    print(json.dumps(run), flush=True)
                    out.write_text(json.dumps({"config": args.config, "runs": runs}, indent=2))
    print()
    print(table(runs))


if __name__ == "__main__":
    main()
