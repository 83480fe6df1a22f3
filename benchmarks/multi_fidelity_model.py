"""Does a cheap level teach the fine response model? (issue 38, item 4, the model alone)

On the analytic cylinder lift (two free frictions, the quickstart's box), the fine level is
the closed-form model with 1 % noise; each cheaper level is the analytic engine's distortion
of it (``demcal.engines.analytic.distorted``) at a tenth of the fine CPU:

- ``biased``: scale 0.9 on every response, bias +3° on the angle, 2 % noise;
- ``poor``: a ripple of relative amplitude 0.4 across the box, 2 % noise (poorly
  correlated with fine on purpose).

For each seed and a budget of B fine-run equivalents, two ways to spend it:

- fine only: B fine runs (a Sobol design), one Kriging per response
  (``KrigingSurrogate``, the optimizer's response model);
- multi-fidelity: B/2 fine runs and 5 B coarse runs (the other half of the budget),
  ``MultiFidelityKriging``.

Measured on 512 Sobol test points of the box against the noise-free fine response: the RMSE
of each response's prediction, and the share of test points within 2 predicted sd of the
truth (coverage). Medians and ranges over the seeds.

    OMP_NUM_THREADS=1 python benchmarks/multi_fidelity_model.py --seeds 10 --budget 10

Writes benchmarks/results/multi_fidelity_model.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.stats import qmc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from demcal.engines.analytic import distorted  # noqa: E402
from demcal.optimizer.surrogates.kriging import KrigingSurrogate  # noqa: E402
from demcal.optimizer.surrogates.multi_fidelity import (  # noqa: E402
    LevelData,
    MultiFidelityKriging,
)
from demcal.scenes.cylinder_lift.analytic import analytic_model  # noqa: E402

LOWER, UPPER = np.array([0.1, 0.02]), np.array([0.9, 0.3])
FIXED = {
    "sliding_friction_pw": 0.5,
    "rolling_friction_pw": 0.1,
    "restitution_pp": 0.5,
    "particle_density": 2500.0,
}
RESPONSES = ("angle_of_repose", "bulk_density")
FINE_NOISE, LEVEL_NOISE = 0.01, 0.02
LEVELS = {
    "biased": {"scale": 0.9, "bias": {"angle_of_repose": 3.0}},
    "poor": {"ripple": 0.4},
}
#: Coarse runs per fine run of the budget: a coarse run costs a tenth of a fine one.
COARSE_PER_FINE = 10


def responses(unit: np.ndarray, level: dict, noise: float, rng: np.random.Generator | None):
    """Each response at the rows of ``unit`` (the box's unit square) at ``level``."""
    out = {name: [] for name in RESPONSES}
    for row in np.atleast_2d(unit):
        values = LOWER + row * (UPPER - LOWER)
        parameters = {
            **FIXED,
            "sliding_friction_pp": float(values[0]),
            "rolling_friction_pp": float(values[1]),
        }
        exact = distorted(analytic_model(parameters, {}), parameters, level)
        for name in RESPONSES:
            factor = 1.0 if rng is None else 1.0 + noise * rng.standard_normal()
            out[name].append(exact[name] * factor)
    return {name: np.array(v) for name, v in out.items()}


def measure(prediction: np.ndarray, sd: np.ndarray, truth: np.ndarray) -> dict:
    return {
        "rmse": float(np.sqrt(np.mean((prediction - truth) ** 2))),
        "coverage_2sd": float(np.mean(np.abs(prediction - truth) <= 2.0 * sd)),
    }


def one_seed(seed: int, budget: int, level: str, test: np.ndarray, truth: dict) -> dict:
    rng = np.random.default_rng(seed)
    fine_only = qmc.Sobol(2, seed=seed).random(budget)
    fine_half = qmc.Sobol(2, seed=seed).random(budget // 2)
    coarse = qmc.Sobol(2, seed=10_000 + seed).random(COARSE_PER_FINE * (budget - budget // 2))
    y_fine_only = responses(fine_only, {}, FINE_NOISE, rng)
    y_fine_half = responses(fine_half, {}, FINE_NOISE, rng)
    y_coarse = responses(coarse, LEVELS[level], LEVEL_NOISE, rng)
    result: dict = {"seed": seed, "level": level}
    for name in RESPONSES:
        start = time.process_time()
        alone = KrigingSurrogate(seed=seed).fit(fine_only, y_fine_only[name])
        single_s = time.process_time() - start
        start = time.process_time()
        multi = MultiFidelityKriging(seed=seed).fit(
            [
                LevelData(coarse, y_coarse[name], np.zeros(len(coarse))),
                LevelData(fine_half, y_fine_half[name], np.zeros(len(fine_half))),
            ]
        )
        multi_s = time.process_time() - start
        result[name] = {
            "fine_only": measure(alone.predict(test), alone.predict_std(test), truth[name])
            | {"fit_cpu_s": single_s},
            "multi_fidelity": measure(multi.predict(test), multi.predict_std(test), truth[name])
            | {"fit_cpu_s": multi_s, "rho": multi.rho},
        }
    return result


def summary(runs: list[dict], level: str) -> list[str]:
    lines = []
    for name in RESPONSES:
        for way in ("fine_only", "multi_fidelity"):
            rmse = [r[name][way]["rmse"] for r in runs if r["level"] == level]
            cover = [r[name][way]["coverage_2sd"] for r in runs if r["level"] == level]
            lines.append(
                f"| {level} | {name} | {way.replace('_', ' ')} | {np.median(rmse):.3g} "
                f"({min(rmse):.3g}–{max(rmse):.3g}) | {np.median(cover):.0%} |"
            )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--budget", type=int, default=10, help="fine-run equivalents")
    args = parser.parse_args()
    warnings.filterwarnings("ignore", message="The balance properties of Sobol")
    test = qmc.Sobol(2, seed=999).random(512)
    truth = responses(test, {}, 0.0, None)
    runs = [
        one_seed(seed, args.budget, level, test, truth)
        for level in LEVELS
        for seed in range(1, args.seeds + 1)
    ]
    out = ROOT / "benchmarks" / "results" / "multi_fidelity_model.json"
    out.write_text(json.dumps({"budget": args.budget, "runs": runs}, indent=1))
    print(f"budget {args.budget} fine runs; {args.seeds} seeds; written {out.relative_to(ROOT)}")
    print("| level | response | way | RMSE median (range) | within 2 sd |")
    print("|---|---|---|---|---|")
    for level in LEVELS:
        print("\n".join(summary(runs, level)))


if __name__ == "__main__":
    main()
