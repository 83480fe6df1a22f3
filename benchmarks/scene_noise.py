"""Noise and cost of a scene at one point: several seeds, the study's engine (real LAMMPS).

    python benchmarks/scene_noise.py CONFIG [--scene NAME] [--seeds 5] [--jobs 2]
                                    [--point NAME=VALUE ...] [--replicates N] [--tag TAG]

Runs one point (default: the middle of the free parameters' bounds; --point
overrides single parameters) once per seed through the same simulate ->
extract jobs as the workflow, in a scratch directory, ``--jobs`` at a time.
Prints a markdown table of each targeted response (mean, standard deviation,
min, max), seconds per simulation and particle-steps per second, and writes
the raw figures to benchmarks/results/noise_<study>_<scene>[_<tag>].json.
Synthetic-truth targets are the means of such a run at the chosen true point.
``--replicates N`` overrides the study's replicates: with a robust material
(``material: {calibration: ..., robust: true}``) N materials are drawn from
the calibration's solution set and run k simulates with the k-th, so the
spread is over materials (and seeds).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from demcal.jobs.steps import extract, simulate
from demcal.results.records import PointRecord
from demcal.results.storage import write_json
from demcal.study.config import load_study
from demcal.study.model import load_frozen, study_record
from demcal.study.study_file import read_study_yaml

ROOT = Path(__file__).resolve().parents[1]
EVALUATION = "noise"


def run_seed(frozen: str, scene: str, replicate: int) -> dict:
    """One simulate -> extract of replicate ``replicate`` (its own seed) in the
    current directory, of the study frozen in ``frozen``."""
    study = load_frozen(frozen)
    start = time.monotonic()
    sim = simulate(study, EVALUATION, scene, replicate)
    responses = extract(
        study, study.files.evaluation(EVALUATION).replicate(scene, replicate).simulation
    )
    return {
        "replicate": replicate,
        "seed": sim.seed,
        "status": sim.status,
        "reason": sim.reason,
        "material": {name: sim.parameters[name] for name in drawn_names(study)},
        "wall_s": time.monotonic() - start,
        **sim.cost,
        **responses.responses,
    }


def drawn_names(study) -> list[str]:
    """The material parameters a robust study draws per replicate (none otherwise)."""
    return sorted({name for draw in study.material_draws for name in draw})


def summary(rows: list[dict], responses: list[str]) -> str:
    lines = ["| quantity | mean | std. dev. | min | max |", "|---|---|---|---|---|"]
    for key in [*responses, "wall_s", "cpu_s", "steps"]:
        values = [r[key] for r in rows if key in r]
        if values:
            sd = statistics.stdev(values) if len(values) > 1 else 0.0
            lines.append(
                f"| {key} | {statistics.fmean(values):.4g} | {sd:.3g} | "
                f"{min(values):.4g} | {max(values):.4g} |"
            )
    rate = [
        r["particle_steps"] / r["cpu_s"] for r in rows if r.get("cpu_s") and "particle_steps" in r
    ]
    if rate:
        lines.append(
            f"| particle-steps per CPU second | {statistics.fmean(rate):.3g} | | "
            f"{min(rate):.3g} | {max(rate):.3g} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--scene", help="default: the study's first scene")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--jobs", type=int, default=2, help="simulations at a time")
    parser.add_argument("--point", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--replicates", type=int, help="the study's replicates instead")
    parser.add_argument("--tag", default="", help="suffix of the result file")
    args = parser.parse_args()
    config = str(Path(args.config).resolve())
    raw = read_study_yaml(config)
    if args.replicates:
        raw["replicates"] = args.replicates
    study = load_study(raw)  # here: a calibrated material is found from this folder
    scene = args.scene or next(iter(study.scenes))
    point = study.centre_point(args.point)
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        frozen = str(Path(scratch) / "study.json")
        write_json(Path(frozen), study_record(study))
        PointRecord(point).write(study.files.evaluation(EVALUATION).params)
        with ProcessPoolExecutor(args.jobs) as pool:
            rows = list(
                pool.map(run_seed, [frozen] * args.seeds, [scene] * args.seeds, range(args.seeds))
            )
    for row in rows:
        print(json.dumps(row))
    name = f"noise_{study.name}_{scene}" + (f"_{args.tag}" if args.tag else "")
    out = ROOT / "benchmarks" / "results" / f"{name}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(
        json.dumps(
            {
                "config": os.path.relpath(config, ROOT),
                "scene": scene,
                "point": point,
                "settings": study.settings[scene],
                "timestep_fraction": study.timestep_fraction,
                "materials": list(study.material_draws),
                "runs": rows,
            },
            indent=2,
        )
    )
    ok = [r for r in rows if r["status"] == "ok"]
    print(f"\n{scene} at {point}: {len(ok)} of {len(rows)} runs ok ({out.name})\n")
    if not ok:
        raise SystemExit("no run succeeded: nothing to summarise")
    print(summary(ok, study.responses_needed(scene)))


if __name__ == "__main__":
    main()
