"""Noise and cost of the default cylinder lift: one point, several seeds, real LAMMPS.

    python benchmarks/cylinder_lift_noise.py [--seeds 5] [--config config/config.yaml]

Runs the default study's centre point (middle of the free parameters' bounds)
once per seed through the same simulate -> extract jobs as the workflow, in a
scratch directory, one simulation at a time. Prints a markdown table: mean and
standard deviation of each response (and the angle by both measures), seconds
per simulation and particle-steps per second; writes the raw figures to
benchmarks/results/cylinder_lift_noise_<study>.json.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from demcal.config import load_study_file
from demcal.evaluation import evaluation_dir, extract, replicate_dir, simulate
from demcal.files import write_json
from demcal.scenes import measure

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    args = parser.parse_args()
    study = load_study_file(args.config)
    scene = "cylinder_lift"
    point = {p.name: 0.5 * (p.lower + p.upper) for p in study.free}
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        write_json(evaluation_dir(study, "noise") / "params.json", {"parameters": point})
        for rep in range(args.seeds):
            start = time.monotonic()
            sim = simulate(study, "noise", scene, rep)
            responses = extract(study, replicate_dir(study, "noise", scene, rep) / "simulation.json")
            row = {"replicate": rep, "seed": sim["seed"], "status": sim["status"],
                   "reason": sim["reason"], "wall_s": time.monotonic() - start, **sim["cost"],
                   **responses["responses"]}
            if sim["status"] == "ok":
                with np.load(replicate_dir(study, "noise", scene, rep) / "state.npz") as state:
                    row["angle_height_radius"] = measure.heap_angle_height_radius(
                        state["heap_x"], state["heap_r"], study.settings[scene]["d50"],
                        bottom_layer=study.settings[scene]["d50"])
            rows.append(row)
            print(json.dumps(row), flush=True)
    out = ROOT / "benchmarks" / "results" / f"cylinder_lift_noise_{study.name}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps({"config": args.config, "point": point,
                               "settings": study.settings[scene], "runs": rows}, indent=2))
    ok = [r for r in rows if r["status"] == "ok"]
    print(f"\npoint {point}, {len(ok)} of {len(rows)} runs ok\n")
    if not ok:
        raise SystemExit("no run succeeded: nothing to summarise")
    print("| quantity | mean | std. dev. | min | max |\n|---|---|---|---|---|")
    for key, label in (("bulk_density", "bulk density [kg/m^3]"),
                       ("angle_of_repose", "angle of repose, flank fit [deg]"),
                       ("angle_height_radius", "angle of repose, arctan(h/r_t) [deg]"),
                       ("wall_s", "seconds per simulation"),
                       ("steps", "time steps")):
        values = [r[key] for r in ok]
        print(f"| {label} | {statistics.fmean(values):.4g} | "
              f"{statistics.stdev(values) if len(values) > 1 else 0:.3g} | "
              f"{min(values):.4g} | {max(values):.4g} |")
    rate = [r["particle_steps"] / r["wall_s"] for r in ok]
    print(f"| particle-steps per second | {statistics.fmean(rate):.3g} | "
          f"{statistics.stdev(rate) if len(rate) > 1 else 0:.2g} | {min(rate):.3g} | "
          f"{max(rate):.3g} |")


if __name__ == "__main__":
    main()
