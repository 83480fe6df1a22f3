"""LIGGGHTS against LAMMPS on the cylinder lift: wall time per simulation and the two responses.

    python benchmarks/liggghts_vs_lammps.py [--seeds 2] [--cases tiny default]

Both engines run the same study (config/config.yaml: its scene settings and
fixed parameters) at one point, sliding_friction_pp = 0.5 and
rolling_friction_pp = 0.16, through the workflow's simulate -> extract jobs,
one simulation at a time, in a scratch directory. Case ``default`` is the
config's 2000 spheres; ``tiny`` is the tests' 200 spheres of 3 mm lifted at
0.05 m/s. Prints a markdown table (mean +- standard deviation over seeds)
and writes the raw figures to benchmarks/results/liggghts_vs_lammps.json.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import statistics
import subprocess
import tempfile
from pathlib import Path

import yaml

from demcal.jobs.steps import extract, simulate
from demcal.results.records import PointRecord
from demcal.scenes.cylinder_lift import TINY_SETTINGS
from demcal.study.config import load_study

ROOT = Path(__file__).resolve().parents[1]
POINT = {"sliding_friction_pp": 0.5, "rolling_friction_pp": 0.16}
CASES = {"default": {}, "tiny": TINY_SETTINGS}
ENGINES = ("lammps", "liggghts")
RESPONSES = ("bulk_density", "angle_of_repose")


def study_for(config: dict, engine: str, case: str):
    config = copy.deepcopy(config)
    config["study"] = f"{engine}-{case}"
    config["engine"] = {"name": engine}
    config["scenes"]["cylinder_lift"]["settings"].update(CASES[case])
    return load_study(config)


def mean_sd(values: list[float]) -> str:
    if not values:
        return "-"
    sd = statistics.stdev(values) if len(values) > 1 else 0.0
    return f"{statistics.mean(values):.4g} ± {sd:.2g}"


def code_state() -> dict:
    """The commit and the uncommitted files of the checkout the runs used."""

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, check=False
        ).stdout.strip()

    return {
        "head": git("rev-parse", "HEAD"),
        "modified": [
            line[3:] for line in git("status", "--porcelain").splitlines() if line.startswith(" M")
        ],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--cases", nargs="+", default=["tiny", "default"], choices=CASES)
    parser.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    args = parser.parse_args()
    config = yaml.safe_load(Path(args.config).read_text())
    runs, code = [], code_state()
    with tempfile.TemporaryDirectory() as scratch:
        os.chdir(scratch)
        for case in args.cases:
            for engine in ENGINES:
                study = study_for(config, engine, case)
                PointRecord(POINT).write(study.files.evaluation("point").params)
                for rep in range(args.seeds):
                    load_before = os.getloadavg()[0]
                    sim = simulate(study, "point", "cylinder_lift", rep)
                    out = extract(
                        study,
                        study.files.evaluation("point").replicate("cylinder_lift", rep).simulation,
                    )
                    run = {
                        "case": case,
                        "engine": engine,
                        "version": study.engine.version(),
                        "replicate": rep,
                        "seed": sim.seed,
                        "status": sim.status,
                        "reason": sim.reason,
                        "load_before": load_before,
                        **sim.cost,
                        **out.responses,
                    }
                    runs.append(run)
                    print(json.dumps(run), flush=True)
    print("\n| case | engine | wall s | steps | bulk density kg/m³ | angle of repose ° |")
    print("|---|---|---|---|---|---|")
    for case in args.cases:
        for engine in ENGINES:
            ok = [
                r
                for r in runs
                if r["case"] == case and r["engine"] == engine and r["status"] == "ok"
            ]
            print(
                f"| {case} | {engine} | {mean_sd([r['wall_s'] for r in ok])} | "
                f"{mean_sd([r['steps'] for r in ok])} | "
                + " | ".join(mean_sd([r[name] for r in ok if name in r]) for name in RESPONSES)
                + " |"
            )
    out = ROOT / "benchmarks" / "results" / "liggghts_vs_lammps.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(
        json.dumps(
            {
                "code": code,
                "point": POINT,
                "cases": {c: CASES[c] for c in args.cases},
                "fixed": config.get("fixed", {}),
                "timestep_fraction": config.get("timestep_fraction"),
                "runs": runs,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
