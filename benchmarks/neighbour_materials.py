"""New simulations to a run within both spreads, for a material the archive has neighbours of
(issue 38, item 7), analytic engine.

The archive holds full calibrations (max_evaluations 20, as ``demcal run`` runs them) of the
analytic cylinder lift with its two frictions free, at particle densities other than the new
material's: ``one`` archive, a study at 2500 kg/m^3 (truth sliding 0.3, rolling 0.06);
``two``, that one and a study at 2400 kg/m^3 (truth 0.45, 0.25). The new study's material has
2600 kg/m^3 and its truth at sliding 0.5, rolling 0.16; its targets are the noise-free
responses there with the quickstart's spreads (1.5 deg, 5 kg/m^3) and noise (3 % on the
angle, 0.3 % on the bulk density). It runs, per seed and archive, three ways:

- from scratch (``reuse: false``);
- ``reuse: archive``: the archive's runs of the same material, of which there are none;
- ``reuse: neighbours``: the runs of the neighbouring materials, their particle density an
  input of the response models (docs/archive.md).

Counted as in benchmarks/README.md, "Reuse on LAMMPS": the new simulations until the first
whose responses meet both targets within their spreads; also the new simulations in all
(search and 2 confirmation runs, no mapping) and whether the confirmation met both.

    OMP_NUM_THREADS=1 python benchmarks/neighbour_materials.py --seeds 5

Writes benchmarks/results/neighbour_materials.csv and prints the medians.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "benchmarks")]

from fidelity_calibration import (  # noqa: E402
    LOWER,
    NOISE,
    UPPER,
    outcome,
    targets_at,
    truth_responses,
    write_summary,
)
from helpers import InProcessLauncher  # noqa: E402

from demcal.daemon.loop import Calibration  # noqa: E402
from demcal.study.config import load_study  # noqa: E402
from demcal.study.model import freeze  # noqa: E402

#: the archive's studies: particle density (kg/m^3) and truth
ARCHIVED = {
    2500.0: {"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.06},
    2400.0: {"sliding_friction_pp": 0.45, "rolling_friction_pp": 0.25},
}
ARCHIVES = {"one": (2500.0,), "two": (2500.0, 2400.0)}
NEW_DENSITY = 2600.0
NEW_TRUTH = {"sliding_friction_pp": 0.5, "rolling_friction_pp": 0.16}
WAYS = ("scratch", "archive", "neighbours")


def study_config(name: str, density: float, truth: dict[str, float], seed: int) -> dict:
    """The analytic cylinder lift of material ``density`` with targets at ``truth``."""
    fixed = {"restitution_pp": 0.5, "particle_density": density}
    return {
        "study": name,
        "engine": {"name": "analytic", "noise": NOISE, "cpu": 60.0},
        "parameters": {p: {"lower": LOWER[p], "upper": UPPER[p]} for p in LOWER},
        "fixed": fixed,
        "targets": targets_at(truth_responses(truth, fixed)),
        "replicates": 1,
        "seed": seed,
        "optimizer": {"max_evaluations": 20, "confirm_replicates": 2},
        "calibration": {"poll_seconds": 0.001, "retries": 1},
    }


def calibrate(config: dict) -> Calibration:
    study = freeze(load_study(config))
    calibration = Calibration(study, InProcessLauncher(study), workers=2)
    calibration.run(show_progress=lambda progress: None)
    return calibration


def first_within(calibration: Calibration) -> int | None:
    """The number of new simulations up to the first whose responses all meet their targets
    within their spreads (None if none did)."""
    study = calibration.study
    table = pd.read_csv(study.files.evaluations_csv)
    table = table[table["origin"].isin(["new", "confirmation", "mapping"])]
    for count, (_, row) in enumerate(table.iterrows(), start=1):
        if all(abs(row[t.key] - t.value) <= (t.spread or 0.0) for t in study.targets):
            return count
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for archive, densities in ARCHIVES.items():
            base = Path(folder, archive)
            base.mkdir()
            os.chdir(base)
            for density in densities:
                calibrate(study_config(f"archived-{density:.0f}", density, ARCHIVED[density], 1))
            for seed in range(1, args.seeds + 1):
                for way in WAYS:
                    if way == "archive" and archive == "two":
                        continue  # no run of the same material in either archive
                    here = Path(folder, f"{archive}-{seed}-{way}")
                    shutil.copytree(base, here)
                    os.chdir(here)
                    config = study_config("new", NEW_DENSITY, NEW_TRUTH, seed)
                    if way != "scratch":
                        config["reuse"] = way
                    calibration = calibrate(config)
                    rows.append(
                        {
                            "archive": archive,
                            "seed": seed,
                            "way": way,
                            "neighbour_points": len(calibration.optimizer.neighbour_records),
                            "first_within": first_within(calibration),
                            **outcome(calibration.study, NEW_TRUTH, LOWER, UPPER),
                        }
                    )
                    print(rows[-1], flush=True)
    write_summary(
        rows,
        "neighbour_materials",
        ["archive", "way"],
        first_within_median=("first_within", "median"),
        first_within_max=("first_within", "max"),
    )


if __name__ == "__main__":
    main()
