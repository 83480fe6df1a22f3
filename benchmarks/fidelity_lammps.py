"""CPU to a confirmed answer on LAMMPS, multi-fidelity against fine only (issue 38).

One study file with a coarse level (``fidelities:``) is run as ``demcal run`` runs it, once per
seed and arm: fine only (``optimizer.fidelity`` removed) and multi-fidelity
(``optimizer.fidelity: coarse``), with no mapping (``map_solutions: 0``), so that a run ends
when its answer is confirmed or its budget is spent. Per run (the measures of
``benchmarks/fidelity_calibration.py``): the fine and coarse simulations, the CPU the engine
reports for every simulation (confirmations included), whether the mean of the confirmation
runs meets every target within its spread, and, with ``--truth``, whether the truth lies inside
the reported likely spans.

    OMP_NUM_THREADS=1 python benchmarks/fidelity_lammps.py \\
        benchmarks/results/fidelity_quickstart_mf.yaml --seeds 5 \\
        --truth sliding_friction_pp=0.3 rolling_friction_pp=0.06
    OMP_NUM_THREADS=1 python benchmarks/fidelity_lammps.py \\
        benchmarks/results/fidelity_rig_mf.yaml --seeds 3

Writes benchmarks/results/fidelity_lammps_<study>.csv (one row per run; the rows so far to
fidelity_lammps_<study>_partial.csv after every run) and prints the medians. ``--first-seed``
adds seeds to a table cut short: the table's rows of other seeds are kept beside the new ones.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from fidelity_calibration import outcome, write_summary  # noqa: E402

from demcal.study.config import load_study  # noqa: E402
from demcal.study.model import freeze  # noqa: E402
from demcal.study.study_file import read_study_yaml  # noqa: E402

ARMS = ("fine only", "coarse")
RESULTS = ROOT / "benchmarks" / "results"


def arm_config(base: dict, seed: int, arm: str) -> dict:
    """The study of one seed and arm: the base study with its seed, its own name, no mapping,
    and the coarse level spent only in the multi-fidelity arm."""
    config = yaml.safe_load(yaml.safe_dump(base))
    config["study"] = f"{base['study']}-s{seed}-{'fine' if arm == 'fine only' else arm}"
    config["seed"] = seed
    optimizer = config.setdefault("optimizer", {})
    optimizer["map_solutions"] = 0
    optimizer.pop("fidelity", None)
    if arm != "fine only":
        optimizer["fidelity"] = arm
    return config


def one_run(base: dict, seed: int, arm: str, truth: dict[str, float] | None, workers: int) -> dict:
    config = arm_config(base, seed, arm)
    path = Path(f"{config['study']}.yaml")
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    start = time.monotonic()
    command = [sys.executable, "-m", "demcal.cli", "run", str(path), "--workers", str(workers)]
    finished = subprocess.run(command, capture_output=True, text=True, check=False)
    Path(f"{config['study']}.out").write_text(finished.stdout + finished.stderr)
    if finished.returncode != 0:
        raise SystemExit(f"{config['study']} failed:\n{finished.stdout}{finished.stderr}")
    study = freeze(load_study(config))
    lower = {free.name: free.lower for free in study.free}
    upper = {free.name: free.upper for free in study.free}
    return {
        "study": base["study"],
        "seed": seed,
        "arm": arm,
        "exit": finished.returncode,
        **outcome(study, truth, lower, upper),
        "wall_s": time.monotonic() - start,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", type=Path)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--truth", nargs="*", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    base = read_study_yaml(args.study)
    truth = {k: float(v) for k, v in (item.split("=", 1) for item in args.truth)} or None
    name = f"fidelity_lammps_{base['study']}"
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    rows = earlier_rows(RESULTS / f"{name}.csv", seeds)
    with tempfile.TemporaryDirectory() as folder:
        os.chdir(folder)
        for seed in seeds:
            for arm in ARMS:
                rows.append(one_run(base, seed, arm, truth, args.workers))
                print(rows[-1], flush=True)
                # kept if the run is cut short
                pd.DataFrame(rows).to_csv(RESULTS / f"{name}_partial.csv", index=False)
    write_summary(rows, name, "arm")


def earlier_rows(table: Path, seeds: range) -> list[dict]:
    """The rows of an earlier run of the same study for seeds other than ``seeds``."""
    if not table.exists():
        return []
    earlier = pd.read_csv(table)
    return earlier[~earlier["seed"].isin(seeds)].to_dict("records")


if __name__ == "__main__":
    main()
