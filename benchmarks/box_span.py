"""Responses at the centre and every corner of a study's box: do they span its targets?

    python benchmarks/box_span.py CONFIG [--jobs 2] [--tag TAG]

Runs one simulation (replicate 0's seed) at the centre of the free parameters' bounds and at
each of their 2^d corners, through the workflow's simulate -> extract jobs in a scratch
directory, ``--jobs`` at a time. Prints a markdown table of the points and their responses,
then each target against the smallest and largest response found: a calibration can only
meet a target that the box spans. Raw figures: benchmarks/results/span_<study>[_<tag>].json.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from demcal.jobs.steps import extract, simulate
from demcal.results.records import PointRecord
from demcal.study.config import load_study_file

ROOT = Path(__file__).resolve().parents[1]


def run_point(config: str, evaluation: str) -> dict:
    """simulate -> extract of every scene of one evaluation (replicate 0)."""
    study = load_study_file(config)
    row: dict = {"evaluation": evaluation}
    for scene in study.scenes:
        start = time.monotonic()
        sim = simulate(study, evaluation, scene, 0)
        responses = extract(
            study, study.files.evaluation(evaluation).replicate(scene, 0).simulation
        )
        row.update(
            {
                f"{scene}.status": responses.status,
                f"{scene}.reason": responses.reason,
                f"{scene}.wall_s": time.monotonic() - start,
                f"{scene}.cpu_s": sim.cost.get("cpu_s"),
                **{f"{scene}.{n}": v for n, v in responses.responses.items()},
            }
        )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--jobs", type=int, default=2, help="simulations at a time")
    parser.add_argument("--tag", default="", help="suffix of the result file")
    args = parser.parse_args()
    config = str(Path(args.config).resolve())
    study = load_study_file(config)
    names = [p.name for p in study.free]
    points = {"centre": study.centre_point()}
    for i, corner in enumerate(itertools.product(*[(p.lower, p.upper) for p in study.free])):
        points[f"corner{i}"] = dict(zip(names, corner))
    start = time.monotonic()
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        for evaluation, point in points.items():
            PointRecord(point).write(study.files.evaluation(evaluation).params)
        with ProcessPoolExecutor(args.jobs) as pool:
            rows = list(pool.map(run_point, [config] * len(points), list(points)))
    wall = time.monotonic() - start
    for row in rows:
        row.update(points[row["evaluation"]])
    keys = [f"{t.scene}.{t.response}" for t in study.targets]
    print("| point | " + " | ".join(names + keys) + " | CPU s |")
    print("|---" * (len(names) + len(keys) + 2) + "|")
    for row in rows:
        cpu = sum(row.get(f"{s}.cpu_s") or 0.0 for s in study.scenes)
        cells = [f"{row[n]:.4g}" for n in names] + [
            f"{row[k]:.4g}" if k in row else "failed" for k in keys
        ]
        print(f"| {row['evaluation']} | " + " | ".join(cells) + f" | {cpu:.0f} |")
    print(f"\n{len(rows)} simulations, {wall / 60:.1f} min wall with {args.jobs} at a time\n")
    for target, key in zip(study.targets, keys):
        values = [row[key] for row in rows if key in row]
        low, high = (min(values), max(values)) if values else (float("nan"), float("nan"))
        spans = "yes" if low <= target.value <= high else "NO"
        print(f"- {key}: target {target.value:g}, box gives {low:.4g} to {high:.4g}: {spans}")
    name = f"span_{study.name}" + (f"_{args.tag}" if args.tag else "")
    out = ROOT / "benchmarks" / "results" / f"{name}.json"
    out.write_text(
        json.dumps(
            {
                "config": os.path.relpath(config, ROOT),
                "settings": study.settings,
                "fixed": study.fixed,
                "wall_s": wall,
                "points": rows,
            },
            indent=2,
        )
    )
    print(f"\nraw figures: {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
