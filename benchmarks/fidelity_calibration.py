"""CPU to a confirmed answer, multi-fidelity against fine only (issue 38), analytic engine.

The analytic cylinder lift with its two frictions free, at three truths; the targets are
the noise-free fine responses at the truth with the quickstart's spreads, 1.5 deg (angle)
and 5 kg/m^3 (bulk density). A fine run costs 60 CPU s with the quickstart's noise (3 % on the
angle, 0.3 % on the bulk density: benchmarks/README.md, scene noise). Each cheaper level
costs 6 CPU s with twice that noise (``demcal.engines.analytic``):

- ``biased``: every response scaled by 0.9, the angle shifted by +3 deg;
- ``poor``: a ripple of relative amplitude 0.4 across the box (poorly correlated).

Each study runs as ``demcal run`` runs it (the daemon's loop, its default response_ei search,
stop_when_known, 2 confirmation runs, max_evaluations 30), in this process
(``InProcessLauncher`` of tests/helpers.py, two workers): fine only, and with
``optimizer.fidelity`` set to each level. Per run:

- CPU: the analytic engine's reported CPU of every simulation, confirmations included;
- confirmed: the mean of the confirmation runs meets every target within its spread;
- truth in set: the truth lies inside the reported likely span of both parameters
  (``demcal.analysis.solution_report.analyse``, as the report computes it);
- the answer's distance to the truth (unit box).

    OMP_NUM_THREADS=1 python benchmarks/fidelity_calibration.py --seeds 5

Writes benchmarks/results/fidelity_calibration.csv (one row per run) and prints the medians.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from helpers import InProcessLauncher  # noqa: E402

from demcal.analysis.solution_report import analyse  # noqa: E402
from demcal.daemon.loop import Calibration  # noqa: E402
from demcal.results.layout import REUSED_ORIGINS  # noqa: E402
from demcal.results.records import BestRecord  # noqa: E402
from demcal.scenes.cylinder_lift.analytic import analytic_model  # noqa: E402
from demcal.study.config import load_study  # noqa: E402
from demcal.study.model import Study, freeze  # noqa: E402

FIXED = {"restitution_pp": 0.5, "restitution_pw": 0.5, "particle_density": 2500.0}
LOWER = {"sliding_friction_pp": 0.1, "rolling_friction_pp": 0.02}
UPPER = {"sliding_friction_pp": 0.9, "rolling_friction_pp": 0.3}
TRUTHS = {
    "a": {"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.06},
    "b": {"sliding_friction_pp": 0.6, "rolling_friction_pp": 0.15},
    "c": {"sliding_friction_pp": 0.45, "rolling_friction_pp": 0.25},
}
SPREADS = {"angle_of_repose": 1.5, "bulk_density": 5.0}
NOISE = {"angle_of_repose": 0.03, "bulk_density": 0.003}
UNITS = {"angle_of_repose": "deg", "bulk_density": "kg/m^3"}
LEVELS = {
    "biased": {"scale": 0.9, "bias": {"angle_of_repose": 3.0}},
    "poor": {"ripple": 0.4},
}
FINE_CPU, LEVEL_CPU = 60.0, 6.0


def truth_responses(truth: dict[str, float], fixed: dict[str, float] = FIXED) -> dict[str, float]:
    """The noise-free fine responses at ``truth`` (the analytic engine's defaults around it)."""
    from demcal.physics.catalogue import CATALOG

    parameters = {name: spec.default for name, spec in CATALOG.items()}
    return analytic_model({**parameters, **fixed, **truth}, {})


def targets_at(exact: dict[str, float]) -> list[dict]:
    """The cylinder lift's targets at the responses ``exact``, with the quickstart's spreads."""
    return [
        {
            "scene": "cylinder_lift",
            "response": response,
            "value": float(exact[response]),
            "unit": UNITS[response],
            "spread": SPREADS[response],
        }
        for response in SPREADS
    ]


def study_config(name: str, truth: dict[str, float], seed: int, level: str | None) -> dict:
    exact = truth_responses(truth)
    config = {
        "study": name,
        "engine": {"name": "analytic", "noise": NOISE, "cpu": FINE_CPU},
        "parameters": {p: {"lower": LOWER[p], "upper": UPPER[p]} for p in LOWER},
        "fixed": FIXED,
        "targets": targets_at(exact),
        "seed": seed,
        "optimizer": {"max_evaluations": 30, "confirm_replicates": 2},
        "calibration": {"poll_seconds": 0.001, "retries": 1},
    }
    if level is not None:
        config["fidelities"] = {
            "coarse": {
                "engine": {
                    "noise": {name: 2.0 * sd for name, sd in NOISE.items()},
                    "cpu": LEVEL_CPU,
                    **LEVELS[level],
                }
            }
        }
        config["optimizer"]["fidelity"] = "coarse"
    return config


def one_run(truth_name: str, seed: int, level: str | None) -> dict:
    truth = TRUTHS[truth_name]
    name = f"{truth_name}-{seed}-{level or 'fine'}"
    start = time.monotonic()
    study = freeze(load_study(study_config(name, truth, seed, level)))
    calibration = Calibration(study, InProcessLauncher(study), workers=2)
    reason = calibration.run(show_progress=lambda progress: None)
    return {
        "truth": truth_name,
        "seed": seed,
        "level": level or "fine only",
        "reason": reason,
        **outcome(study, truth, LOWER, UPPER),
        "wall_s": time.monotonic() - start,
    }


def write_summary(rows: list[dict], name: str, by: str | list[str], **extra: tuple) -> None:
    """Write ``rows`` to benchmarks/results/<name>.csv and print, per group ``by``, the
    medians and spread of the CPU and runs, the share confirmed and with the truth in the set
    (and the ``extra`` aggregations, pandas' named form)."""
    table = pd.DataFrame(rows)
    out = ROOT / "benchmarks" / "results" / f"{name}.csv"
    table.to_csv(out, index=False)
    summary = table.groupby(by).agg(
        runs=("cpu_s", "size"),
        cpu_median_s=("cpu_s", "median"),
        cpu_q25=("cpu_s", lambda s: s.quantile(0.25)),
        cpu_q75=("cpu_s", lambda s: s.quantile(0.75)),
        fine_runs=("fine_runs", "median"),
        cheap_runs=("cheap_runs", "median"),
        confirmed=("confirmed", "mean"),
        truth_in_set=("truth_in_set", "mean"),
        **extra,
    )
    print(summary.to_string())
    print(f"written {out.relative_to(ROOT)}")


def outcome(
    study: Study,
    truth: dict[str, float] | None,
    lower: dict[str, float],
    upper: dict[str, float],
) -> dict:
    """A finished study's new runs and CPU per level, whether its confirmation met every target
    within its spread, and (with a known ``truth``) whether the truth lies inside the reported
    likely spans and how far the answer is from it in the unit box."""
    table = pd.read_csv(study.files.evaluations_csv)
    table = table[~table["origin"].isin(REUSED_ORIGINS)]  # new simulations only
    cpu = pd.to_numeric(table["cpu_s"], errors="coerce").fillna(0.0)
    fine = table["fidelity"] == "fine"
    best = BestRecord.read(study.files.best)
    confirmed = (best.confirmation or {}).get("responses", {})
    meets = bool(confirmed) and all(
        abs(confirmed[t.key]["mean"] - t.value) <= (t.spread or 0.0) for t in study.targets
    )
    row = {
        "fine_runs": int(fine.sum()),
        "cheap_runs": int((~fine).sum()),
        "cpu_s": float(cpu.sum()),
        "cheap_cpu_s": float(cpu[~fine].sum()),
        "confirmed": meets,
        "truth_in_set": None,
        "answer_error_unit": None,
    }
    if truth is not None:
        analysis = analyse(study)
        row["truth_in_set"] = all(v.low <= truth[v.name] <= v.high for v in analysis.verdicts)
        unit = [(best.parameters[p] - truth[p]) / (upper[p] - lower[p]) for p in truth]
        row["answer_error_unit"] = float(np.linalg.norm(unit))
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--levels", nargs="*", default=[None, *LEVELS])
    args = parser.parse_args()
    levels = [None if level in (None, "none") else level for level in args.levels]
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        os.chdir(folder)
        for truth in TRUTHS:
            for seed in range(1, args.seeds + 1):
                for level in levels:
                    rows.append(one_run(truth, seed, level))
                    print(rows[-1], flush=True)
    write_summary(
        rows, "fidelity_calibration", "level", answer_error=("answer_error_unit", "median")
    )


if __name__ == "__main__":
    main()
