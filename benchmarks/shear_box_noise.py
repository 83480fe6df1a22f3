"""Noise and cost of the shear box: one point, several seeds, real LAMMPS.

    python benchmarks/shear_box_noise.py [--seeds 3] [--config config/examples/shear_box.yaml]

Runs the study's centre point (middle of the free parameters' bounds) once
per seed through the same simulate -> extract jobs as the workflow, in a
scratch directory, one simulation at a time. Prints a markdown table: mean
and standard deviation of each targeted response, seconds per simulation and
particle-steps per second; writes the raw figures to
benchmarks/results/shear_box_noise_<study>.json.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from demcal.config import load_study_file
from demcal.evaluation import evaluation_dir, extract, replicate_dir, simulate
from demcal.files import write_json

ROOT = Path(__file__).resolve().parents[1]
SCENE = "shear_box"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--config", default=str(ROOT / "config" / "examples" / "shear_box.yaml"))
    args = parser.parse_args()
    study = load_study_file(Path(args.config).resolve())
    point = {p.name: 0.5 * (p.lower + p.upper) for p in study.free}
    responses = study.responses_needed(SCENE)
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        write_json(evaluation_dir(study, "noise") / "params.json", {"parameters": point})
        for rep in range(args.seeds):
            start = time.monotonic()
            sim = simulate(study, "noise", SCENE, rep)
            extracted = extract(study, replicate_dir(study, "noise", SCENE, rep) / "simulation.json")
            rows.append({"replicate": rep, "seed": sim["seed"], "status": sim["status"],
                         "reason": sim["reason"], "wall_s": time.monotonic() - start,
                         **sim["cost"], **sim["measurements"], **extracted["responses"]})
            print(json.dumps(rows[-1]), flush=True)
    out = ROOT / "benchmarks" / "results" / f"shear_box_noise_{study.name}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"config": args.config, "point": point, "fixed": study.fixed,
                               "settings": study.settings[SCENE], "runs": rows}, indent=2))
    ok = [r for r in rows if r["status"] == "ok"]
    print(f"\npoint {point}, {len(ok)} of {len(rows)} runs ok\n")
    if not ok:
        raise SystemExit("no run succeeded: nothing to summarise")
    print("| quantity | mean | std. dev. | min | max |\n|---|---|---|---|---|")
    for key in [*responses, "wall_s", "steps", "particles", "particles_left"]:
        values = [r[key] for r in ok]
        print(f"| {key} | {statistics.fmean(values):.4g} | "
              f"{statistics.stdev(values) if len(values) > 1 else 0:.3g} | "
              f"{min(values):.4g} | {max(values):.4g} |")
    rate = [r["particle_steps"] / r["wall_s"] for r in ok]
    print(f"| particle-steps per second | {statistics.fmean(rate):.3g} | "
          f"{statistics.stdev(rate) if len(rate) > 1 else 0:.2g} | {min(rate):.3g} | "
          f"{max(rate):.3g} |")


if __name__ == "__main__":
    main()
