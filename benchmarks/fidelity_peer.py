"""CPU to the noise level with a cheaper level: demcal against BoTorch's multi-fidelity
knowledge gradient (issue 38, the peer), analytic engine.

The problems of ``benchmarks/fidelity_calibration.py``: the analytic cylinder lift with its
two frictions free, three truths, the quickstart's noise and spreads; a fine run costs 60 CPU
s, a run of the ``biased`` level (every response × 0.9, the angle + 3 deg, twice the noise)
6 CPU s. Responses come from demcal's analytic engine (``noisy_responses``), seeded by the seed and
the run's index: every tool's k-th run sees the same draw.

Each tool runs ask/tell, one simulation at a time, until it has spent ``--cpu`` seconds or
made ``MAX_RUNS`` simulations:

- ``demcal``: the Optimizer with ``response_ei`` and the level (``fidelity: coarse``), as
  ``demcal run`` uses it (its initial design at both levels, multi-fidelity response models
  where the level pays, the level of each run by worth per CPU second);
- ``demcal fine``: the same optimizer without the level;
- ``botorch``: BoTorch's ``SingleTaskMultiFidelityGP`` over the two frictions and the level
  (0 coarse, 1 fine) on the scalar objective, ``qMultiFidelityKnowledgeGradient`` with the
  costs as an affine cost model (6 + 54 s CPU s), optimised over both levels
  (``optimize_acqf_mixed``), after the same initial design as demcal's (5 Sobol points at
  both levels); its answer is the maximiser of the posterior mean at the fine level. The GP
  models -log10(objective + noise level): the objective spans four decades over the box.

Measured per run: the CPU spent when the running answer's *true* objective (eq. 3.3, relative
form, of the noise-free fine responses) first falls to the noise level (the objective of the
noise alone, 0.03^2 + 0.003^2), or never within the budget; the CPU spent when its noise-free
fine responses first lie within both spreads (the stricter test here: the angle's noise is
large against its spread); and the true objective of the answer at the end.

    OMP_NUM_THREADS=1 /work/bench-venv/bin/python benchmarks/fidelity_peer.py --seeds 3

Needs the benchmark venv (benchmarks/calibration/README.md, "Setup") with ``botorch``.
Writes benchmarks/results/fidelity_peer.csv and prints the medians.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from fidelity_calibration import (  # noqa: E402
    FINE_CPU,
    FIXED,
    LEVEL_CPU,
    LEVELS,
    LOWER,
    NOISE,
    TRUTHS,
    UPPER,
    targets_at,
    truth_responses,
)

from demcal.engines.analytic import noisy_responses  # noqa: E402
from demcal.optimizer import Optimizer  # noqa: E402
from demcal.optimizer.objective import ResponseObjective, Target, objective_value  # noqa: E402
from demcal.physics.catalogue import CATALOG  # noqa: E402
from demcal.results.records import FINE  # noqa: E402
from demcal.scenes.cylinder_lift.analytic import analytic_model  # noqa: E402

NAMES = list(LOWER)
NOISE_LEVEL = sum(sd**2 for sd in NOISE.values())
#: the engine settings of each level (fidelity_calibration's biased level)
ENGINE = {
    FINE: {"noise": NOISE},
    "coarse": {"noise": {k: 2.0 * v for k, v in NOISE.items()}, **LEVELS["biased"]},
}
COST = {FINE: FINE_CPU, "coarse": LEVEL_CPU}
INITIAL = 5
#: simulations a run may make at most, whatever their CPU (so that a tool spending cheap runs
#: only cannot run for ever)
MAX_RUNS = 60


class Problem:
    """One truth: its targets, the noisy responses of a run at a level, the true objective."""

    def __init__(self, truth: str):
        self.truth = TRUTHS[truth]
        self.targets = [
            Target(t["scene"], t["response"], t["value"], spread=t["spread"])
            for t in targets_at(truth_responses(self.truth))
        ]
        self.defaults = {n: spec.default for n, spec in CATALOG.items()} | FIXED

    def responses(self, x: list[float], level: str, seed: int) -> dict[str, float]:
        parameters = self.defaults | dict(zip(NAMES, x))
        found = noisy_responses(analytic_model, parameters, {}, ENGINE[level], seed)
        return {f"cylinder_lift.{k}": v for k, v in found.items()}

    def objective(self, responses: dict[str, float]) -> float:
        return objective_value(self.targets, responses)

    def exact(self, x: list[float]) -> dict[str, float]:
        found = analytic_model(self.defaults | dict(zip(NAMES, x)), {})
        return {f"cylinder_lift.{k}": v for k, v in found.items()}

    def true_objective(self, x: list[float]) -> float:
        return self.objective(self.exact(x))

    def within_spreads(self, x: list[float]) -> bool:
        exact = self.exact(x)
        return all(abs(exact[t.key] - t.value) <= (t.spread or 0.0) for t in self.targets)


def run_seed(seed: int, index: int) -> int:
    """The noise seed of a tool's ``index``-th run: the same for every tool."""
    return zlib.crc32(f"{seed}/{index}".encode())


def demcal_tool(problem: Problem, seed: int, budget: float, level: bool) -> list[tuple]:
    """(CPU so far, answer) after each run of demcal's optimizer."""
    settings = {"strategy": "response_ei", "max_evaluations": 200, "stop_when_known": False}
    if level:
        settings["fidelity"] = "coarse"
    optimizer = Optimizer(
        LOWER_BOUNDS,
        UPPER_BOUNDS,
        settings,
        seed=seed,
        objective=ResponseObjective(tuple(problem.targets)),
    )
    spent, trace, index = 0.0, [], 0
    while spent < budget and index < MAX_RUNS:
        proposals = optimizer.ask()
        if not proposals:
            break
        proposal = proposals[0]
        found = problem.responses(proposal.x, proposal.fidelity, run_seed(seed, index))
        index += 1
        spent += COST[proposal.fidelity]
        optimizer.tell(
            proposal.id,
            responses={k: [v] for k, v in found.items()},
            cpu_s=COST[proposal.fidelity],
        )
        best = optimizer.best()
        trace.append((spent, None if best is None else best.x, proposal.fidelity))
    return trace


def botorch_tool(problem: Problem, seed: int, budget: float) -> list[tuple]:
    """(CPU so far, answer) after each run of BoTorch's multi-fidelity knowledge gradient."""
    import torch
    from botorch.acquisition import PosteriorMean
    from botorch.acquisition.cost_aware import InverseCostWeightedUtility
    from botorch.acquisition.fixed_feature import FixedFeatureAcquisitionFunction
    from botorch.acquisition.knowledge_gradient import qMultiFidelityKnowledgeGradient
    from botorch.acquisition.utils import project_to_target_fidelity
    from botorch.fit import fit_gpytorch_mll
    from botorch.models.cost import AffineFidelityCostModel
    from botorch.models.gp_regression_fidelity import SingleTaskMultiFidelityGP
    from botorch.models.transforms.outcome import Standardize
    from botorch.optim.optimize import optimize_acqf, optimize_acqf_mixed
    from gpytorch.mlls.exact_marginal_log_likelihood import ExactMarginalLogLikelihood
    from scipy.stats import qmc

    torch.manual_seed(seed)
    lower, upper = np.array(LOWER_BOUNDS), np.array(UPPER_BOUNDS)
    bounds = torch.tensor([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], dtype=torch.double)
    cost_model = AffineFidelityCostModel(
        fidelity_weights={2: COST[FINE] - COST["coarse"]}, fixed_cost=COST["coarse"]
    )
    utility = InverseCostWeightedUtility(cost_model=cost_model)

    def project(x: torch.Tensor) -> torch.Tensor:
        return project_to_target_fidelity(X=x, target_fidelities={2: 1.0}, d=3)

    rows, values, trace, spent, index = [], [], [], 0.0, 0

    def simulate(unit: np.ndarray, fine: bool) -> None:
        nonlocal spent, index
        level = FINE if fine else "coarse"
        x = (lower + unit * (upper - lower)).tolist()
        found = problem.responses(x, level, run_seed(seed, index))
        index += 1
        spent += COST[level]
        rows.append([*unit, 1.0 if fine else 0.0])
        values.append(-math.log10(problem.objective(found) + NOISE_LEVEL))

    def answer(model) -> list[float]:
        mean = FixedFeatureAcquisitionFunction(PosteriorMean(model), d=3, columns=[2], values=[1])
        best, _ = optimize_acqf(mean, bounds[:, :2], q=1, num_restarts=4, raw_samples=128)
        return (lower + best.detach().numpy()[0] * (upper - lower)).tolist()

    def fitted():
        x = torch.tensor(rows, dtype=torch.double)
        y = torch.tensor(values, dtype=torch.double).unsqueeze(-1)
        model = SingleTaskMultiFidelityGP(
            x, y, data_fidelities=[2], outcome_transform=Standardize(1)
        )
        fit_gpytorch_mll(ExactMarginalLogLikelihood(model.likelihood, model))
        return model

    design = qmc.Sobol(2, seed=seed).random(8)[:INITIAL]  # the first 5 of a balanced 8
    for unit in design:
        simulate(unit, fine=False)
    for unit in design:
        simulate(unit, fine=True)
    model = fitted()
    trace.append((spent, answer(model), FINE))
    while spent < budget and index < MAX_RUNS:
        current = PosteriorMean(model)
        fixed = FixedFeatureAcquisitionFunction(current, d=3, columns=[2], values=[1])
        _, value = optimize_acqf(fixed, bounds[:, :2], q=1, num_restarts=4, raw_samples=128)
        kg = qMultiFidelityKnowledgeGradient(
            model,
            num_fantasies=32,
            current_value=value,
            cost_aware_utility=utility,
            project=project,
        )
        chosen, _ = optimize_acqf_mixed(
            kg,
            bounds,
            q=1,
            num_restarts=4,
            raw_samples=128,
            fixed_features_list=[{2: 0.0}, {2: 1.0}],
        )
        point = chosen.detach().numpy()[0]
        simulate(point[:2], fine=bool(point[2] > 0.5))
        model = fitted()
        trace.append((spent, answer(model), FINE if point[2] > 0.5 else "coarse"))
    return trace


LOWER_BOUNDS = [LOWER[n] for n in NAMES]
UPPER_BOUNDS = [UPPER[n] for n in NAMES]
TOOLS: dict[str, Callable[[Problem, int, float], list[tuple]]] = {
    "demcal": lambda p, s, b: demcal_tool(p, s, b, level=True),
    "demcal fine only": lambda p, s, b: demcal_tool(p, s, b, level=False),
    "botorch MF-KG": botorch_tool,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--cpu", type=float, default=1800.0, help="CPU s each run may spend")
    parser.add_argument("--tools", nargs="*", default=list(TOOLS))
    parser.add_argument("--truths", nargs="*", default=list(TRUTHS))
    args = parser.parse_args()
    rows = []
    out = ROOT / "benchmarks" / "results" / "fidelity_peer.csv"
    for truth in args.truths:
        problem = Problem(truth)
        for seed in range(1, args.seeds + 1):
            for tool in args.tools:
                started = time.perf_counter()
                trace = TOOLS[tool](problem, seed, args.cpu)
                reached = next(
                    (
                        spent
                        for spent, x, _ in trace
                        if x is not None and problem.true_objective(x) <= NOISE_LEVEL
                    ),
                    math.inf,
                )
                within = next(
                    (spent for spent, x, _ in trace if x is not None and problem.within_spreads(x)),
                    math.inf,
                )
                final = trace[-1][1]
                rows.append(
                    {
                        "truth": truth,
                        "seed": seed,
                        "tool": tool,
                        "cpu_to_noise_level_s": reached,
                        "cpu_to_within_spreads_s": within,
                        "final_true_objective": problem.true_objective(final),
                        "fine_runs": sum(level == FINE for _, _, level in trace),
                        "coarse_runs": sum(level != FINE for _, _, level in trace),
                        "tool_seconds": time.perf_counter() - started,
                    }
                )
                print(rows[-1], flush=True)
                pd.DataFrame(rows).to_csv(out, index=False)  # kept if the run is cut short
    table = pd.DataFrame(rows)
    summary = table.groupby("tool").agg(
        runs=("seed", "size"),
        reached=("cpu_to_noise_level_s", lambda s: int(np.isfinite(s).sum())),
        cpu_to_noise_level_median=("cpu_to_noise_level_s", "median"),
        cpu_to_within_spreads_median=("cpu_to_within_spreads_s", "median"),
        final_objective_median=("final_true_objective", "median"),
        fine_runs=("fine_runs", "median"),
        coarse_runs=("coarse_runs", "median"),
        tool_seconds=("tool_seconds", "median"),
    )
    print(f"noise level {NOISE_LEVEL:.3g}")
    print(summary.to_string())
    print(f"written {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
