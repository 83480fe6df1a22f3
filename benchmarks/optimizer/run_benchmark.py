"""Benchmark demcal's optimizer against pySOT, Optuna and scikit-optimize.

Tools: demcal (its default strategy), demcal_kriging_ei (the alternative
strategy, for comparison), pySOT DYCORS and SRBF, Optuna GPSampler and TPE,
scikit-optimize gp_minimize.
Problems: Branin (2-D, 40 evaluations) and Hartmann6 (6-D, 100 evaluations),
each noise-free and with Gaussian noise of sd 2 % of the function's range.
Score: final regret = true (noise-free) value at the point each tool reports
as its best, minus the global optimum; and seconds spent in the tool per
proposal (wall time minus time in the objective). Also an asynchronous run
of demcal with P simulated workers and random evaluation durations.

Run from the repository root, in the benchmark venv (see requirements.txt):

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 nice -n 10 \\
        /work/bench-venv/bin/python benchmarks/optimizer/run_benchmark.py

Quick subset: --seeds 2 --problems branin --tools demcal,pysot_dycors --no-async
Writes results.csv (one row per run), async.csv and RESULTS.md next to this file
(or in --out).
"""

from __future__ import annotations

import argparse
import csv
import heapq
import logging
import math
import os
import platform
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPOSITORY = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPOSITORY))

from demcal.optimizer import Optimizer  # noqa: E402

HERE = Path(__file__).resolve().parent
NOISE_FRACTION = 0.02
RESULT_FIELDS = [
    "tool",
    "problem",
    "noise",
    "seed",
    "evaluations",
    "regret",
    "best_evaluated_regret",
    "seconds_per_proposal",
    "reported_x",
]
TOOLS = (
    "demcal",
    "demcal_kriging_ei",
    "pysot_dycors",
    "pysot_srbf",
    "optuna_gp",
    "optuna_tpe",
    "skopt_gp",
)


# ----------------------------------------------------------------- problems
def branin(x) -> float:
    x1, x2 = float(x[0]), float(x[1])
    b, c = 5.1 / (4 * math.pi**2), 5 / math.pi
    return (x2 - b * x1**2 + c * x1 - 6) ** 2 + 10 * (1 - 1 / (8 * math.pi)) * math.cos(x1) + 10


HARTMANN_A = np.array(
    [
        [10, 3, 17, 3.5, 1.7, 8],
        [0.05, 10, 17, 0.1, 8, 14],
        [3, 3.5, 1.7, 10, 17, 8],
        [17, 8, 0.05, 10, 0.1, 14],
    ]
)
HARTMANN_P = 1e-4 * np.array(
    [
        [1312, 1696, 5569, 124, 8283, 5886],
        [2329, 4135, 8307, 3736, 1004, 9991],
        [2348, 1451, 3522, 2883, 3047, 6650],
        [4047, 8828, 8732, 5743, 1091, 381],
    ]
)
HARTMANN_C = np.array([1.0, 1.2, 3.0, 3.2])


def hartmann6(x) -> float:
    x = np.asarray(x, float)
    return float(-np.sum(HARTMANN_C * np.exp(-np.sum(HARTMANN_A * (x - HARTMANN_P) ** 2, axis=1))))


@dataclass(frozen=True)
class Problem:
    name: str
    function: object
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    budget: int
    optimum: float
    value_range: float  # max - min over the box, for the noise level

    @property
    def dimension(self) -> int:
        return len(self.lower)


PROBLEMS = {
    "branin": Problem(
        "branin", branin, (-5.0, 0.0), (10.0, 15.0), 40, 0.397887357729739, 308.129 - 0.397887
    ),
    "hartmann6": Problem(
        "hartmann6", hartmann6, (0.0,) * 6, (1.0,) * 6, 100, -3.32236801141551, 3.32237
    ),
}


class Objective:
    """Noisy (or not) objective that records the time spent inside it.

    It also keeps the lowest true (noise-free) value it was called at, so a
    run's regret at the reported point can be set against the best point it
    evaluated: the gap is what the choice of the reported point loses.
    """

    def __init__(self, problem: Problem, noise_sd: float, seed: int):
        self.problem = problem
        self.noise_sd = noise_sd
        self.rng = np.random.default_rng(10_000 + seed)
        self.seconds = 0.0
        self.calls = 0
        self.best_true = math.inf

    def __call__(self, x) -> float:
        start = time.perf_counter()
        value = self.problem.function(np.asarray(x, float))
        self.best_true = min(self.best_true, value)
        if self.noise_sd:
            value += self.noise_sd * self.rng.standard_normal()
        self.calls += 1
        self.seconds += time.perf_counter() - start
        return float(value)


# -------------------------------------------------------------------- tools
def run_demcal(problem: Problem, objective: Objective, seed: int, settings: dict | None = None):
    optimizer = Optimizer(
        list(problem.lower),
        list(problem.upper),
        {"max_evaluations": problem.budget, **(settings or {})},
        seed=seed,
    )
    while True:
        proposals = optimizer.ask()
        if not proposals:
            break
        optimizer.tell(proposals[0].id, objective(proposals[0].x))
    return optimizer.best().x


def run_pysot(problem: Problem, objective: Objective, seed: int, strategy_name: str):
    from poap.controller import SerialController
    from pySOT.experimental_design import SymmetricLatinHypercube
    from pySOT.optimization_problems import OptimizationProblem
    from pySOT.strategy import DYCORSStrategy, SRBFStrategy
    from pySOT.surrogate import CubicKernel, LinearTail, RBFInterpolant

    class Wrapped(OptimizationProblem):
        def __init__(self):
            self.dim = problem.dimension
            self.lb = np.array(problem.lower)
            self.ub = np.array(problem.upper)
            self.int_var = np.array([], dtype=int)
            self.cont_var = np.arange(problem.dimension)

        def eval(self, x):
            return objective(x)

    np.random.seed(seed)  # pySOT draws from numpy's global generator
    wrapped = Wrapped()
    surrogate = RBFInterpolant(
        dim=wrapped.dim,
        lb=wrapped.lb,
        ub=wrapped.ub,
        kernel=CubicKernel(),
        tail=LinearTail(wrapped.dim),
    )
    design = SymmetricLatinHypercube(dim=wrapped.dim, num_pts=2 * (wrapped.dim + 1))
    strategy_class = DYCORSStrategy if strategy_name == "dycors" else SRBFStrategy
    controller = SerialController(objective=wrapped.eval)
    controller.strategy = strategy_class(
        max_evals=problem.budget,
        opt_prob=wrapped,
        exp_design=design,
        surrogate=surrogate,
        asynchronous=False,
        batch_size=1,
        num_cand=100 * wrapped.dim,
    )
    result = controller.run()
    return list(result.params[0])


def run_optuna(problem: Problem, objective: Objective, seed: int, sampler_name: str):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    if sampler_name == "gp":
        import torch

        torch.set_num_threads(1)
        sampler = optuna.samplers.GPSampler(seed=seed)
    else:
        sampler = optuna.samplers.TPESampler(seed=seed)
    names = [f"x{i}" for i in range(problem.dimension)]

    def trial_objective(trial):
        return objective(
            [
                trial.suggest_float(n, lo, hi)
                for n, lo, hi in zip(names, problem.lower, problem.upper)
            ]
        )

    study = optuna.create_study(sampler=sampler)
    study.optimize(trial_objective, n_trials=problem.budget)
    return [study.best_trial.params[n] for n in names]


def run_skopt(problem: Problem, objective: Objective, seed: int):
    from skopt import gp_minimize

    result = gp_minimize(
        objective,
        list(zip(problem.lower, problem.upper)),
        n_calls=problem.budget,
        random_state=seed,
    )
    return list(result.x)


RUNNERS = {
    "demcal": run_demcal,
    "demcal_kriging_ei": lambda p, o, s: run_demcal(p, o, s, {"strategy": "kriging_ei"}),
    "pysot_dycors": lambda p, o, s: run_pysot(p, o, s, "dycors"),
    "pysot_srbf": lambda p, o, s: run_pysot(p, o, s, "srbf"),
    "optuna_gp": lambda p, o, s: run_optuna(p, o, s, "gp"),
    "optuna_tpe": lambda p, o, s: run_optuna(p, o, s, "tpe"),
    "skopt_gp": run_skopt,
}


def one_run(tool: str, problem: Problem, noisy: bool, seed: int) -> dict:
    objective = Objective(problem, NOISE_FRACTION * problem.value_range if noisy else 0.0, seed)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reported = RUNNERS[tool](problem, objective, seed)
    total = time.perf_counter() - start
    return {
        "tool": tool,
        "problem": problem.name,
        "noise": "2%" if noisy else "none",
        "seed": seed,
        "evaluations": objective.calls,
        "regret": problem.function(np.asarray(reported, float)) - problem.optimum,
        "best_evaluated_regret": objective.best_true - problem.optimum,
        "seconds_per_proposal": (total - objective.seconds) / max(objective.calls, 1),
        "reported_x": " ".join(f"{v:.6g}" for v in reported),
    }


# ------------------------------------------------------------- asynchronous
def simulate_workers(
    problem: Problem, workers: int, seed: int, noisy: bool
) -> list[tuple[float, float]]:
    """Event simulation of ``workers`` asynchronous workers; durations ~ U(0.5, 1.5).

    Returns (simulated time, regret of the reported best) after each finished evaluation.
    """
    objective = Objective(problem, NOISE_FRACTION * problem.value_range if noisy else 0.0, seed)
    durations = np.random.default_rng(20_000 + seed)
    optimizer = Optimizer(
        list(problem.lower),
        list(problem.upper),
        {"max_evaluations": problem.budget},
        seed=seed,
        workers=workers,
    )
    running: list[tuple[float, int, list[float]]] = []
    now = 0.0
    for proposal in optimizer.ask(workers):
        heapq.heappush(running, (now + durations.uniform(0.5, 1.5), proposal.id, proposal.x))
    curve = []
    while running:
        now, ident, x = heapq.heappop(running)
        optimizer.tell(ident, objective(x))
        curve.append((now, problem.function(np.asarray(optimizer.best().x)) - problem.optimum))
        for proposal in optimizer.ask(1):
            heapq.heappush(running, (now + durations.uniform(0.5, 1.5), proposal.id, proposal.x))
    return curve


def regret_at(curve: list[tuple[float, float]], moment: float) -> float:
    regret = math.inf
    for t, r in curve:
        if t > moment:
            break
        regret = r
    return regret


def time_to_reach(times: np.ndarray, median_regret: np.ndarray, target: float) -> float:
    reached = np.nonzero(median_regret <= target)[0]
    return float(times[reached[0]]) if len(reached) else math.inf


def async_experiment(
    problem: Problem, seeds: list[int], workers: int, noisy: bool, out: Path
) -> dict:
    curves = {p: [simulate_workers(problem, p, s, noisy) for s in seeds] for p in (1, workers)}
    horizon = max(c[-1][0] for c in curves[1])
    times = np.linspace(0.0, horizon, 400)
    median = {
        p: np.array([np.median([regret_at(c, t) for c in curves[p]]) for t in times])
        for p in curves
    }
    target = max(median[1][-1], median[workers][-1])
    t1, tp = time_to_reach(times, median[1], target), time_to_reach(times, median[workers], target)
    with open(out / "async.csv", "a", newline="") as handle:
        writer = csv.writer(handle)
        if handle.tell() == 0:
            writer.writerow(
                [
                    "problem",
                    "noise",
                    "simulated_time",
                    "median_regret_P1",
                    f"median_regret_P{workers}",
                ]
            )
        for t, r1, rp in zip(times[::10], median[1][::10], median[workers][::10]):
            writer.writerow(
                [problem.name, "2%" if noisy else "none", f"{t:.3f}", f"{r1:.6g}", f"{rp:.6g}"]
            )
    return {
        "problem": problem.name,
        "noise": "2%" if noisy else "none",
        "workers": workers,
        "target_regret": target,
        "time_P1": t1,
        "time_P": tp,
        "speedup": t1 / tp if tp > 0 else math.inf,
        "final_P1": median[1][-1],
        "final_P": median[workers][-1],
    }


# ------------------------------------------------------------------ report
def summarise(rows: list[dict]) -> list[dict]:
    table = []
    keys = sorted({(r["problem"], r["noise"]) for r in rows}, key=lambda k: (k[0], k[1] != "none"))
    for problem, noise in keys:
        for tool in TOOLS:
            selected = [
                r
                for r in rows
                if r["problem"] == problem and r["noise"] == noise and r["tool"] == tool
            ]
            if not selected:
                continue
            regrets = np.array([float(r["regret"]) for r in selected])
            best_evaluated = [
                float(r["best_evaluated_regret"])
                for r in selected
                if r.get("best_evaluated_regret")
            ]
            table.append(
                {
                    "problem": problem,
                    "noise": noise,
                    "tool": tool,
                    "runs": len(selected),
                    "median_regret": float(np.median(regrets)),
                    "worst_regret": float(np.max(regrets)),
                    "median_best_evaluated": float(np.median(best_evaluated))
                    if best_evaluated
                    else math.nan,
                    "median_s_per_proposal": float(
                        np.median([float(r["seconds_per_proposal"]) for r in selected])
                    ),
                }
            )
    return table


def write_report(
    table: list[dict],
    async_rows: list[dict],
    command: str,
    out: Path,
    elapsed: float,
    note: str = "",
) -> None:
    lines = [
        "# Optimizer benchmark",
        "",
        f"Command: `{command}`",
        "",
        f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores (shared), "
        f"Python {platform.python_version()}; total {elapsed / 60:.1f} min. Written by "
        "run_benchmark.py.",
        note,
        "",
        "Regret: true function value at the point the tool reports as best, minus the optimum. "
        "Noise: Gaussian, sd 2 % of the function range. Seconds: tool time per proposal (wall "
        "time minus objective time). Best evaluated: median over the runs of the true regret of "
        "the best point each run evaluated (what a perfect choice among its own points would have "
        "reported).",
        "",
        "| problem | noise | tool | runs | median regret | worst regret | median best evaluated | "
        "median s/proposal |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in table:
        lines.append(
            f"| {row['problem']} | {row['noise']} | {row['tool']} | {row['runs']} | "
            f"{row['median_regret']:.3g} | {row['worst_regret']:.3g} | "
            f"{row['median_best_evaluated']:.3g} | {row['median_s_per_proposal']:.3g} |"
        )
    if async_rows:
        lines += [
            "",
            "## Asynchronous workers (demcal, simulated durations U(0.5, 1.5))",
            "",
            "Speedup = simulated time for P=1 to reach the target median regret / time for P "
            "workers; target = the larger of the two final median regrets. Curves in async.csv.",
            "",
            "| problem | noise | P | target regret | time P=1 | time P | speedup | final regret "
            "P=1 | final regret P |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for a in async_rows:
            lines.append(
                f"| {a['problem']} | {a['noise']} | {a['workers']} | {a['target_regret']:.3g} | "
                f"{a['time_P1']:.1f} | {a['time_P']:.1f} | {a['speedup']:.2f} | "
                f"{a['final_P1']:.3g} | {a['final_P']:.3g} |"
            )
    lines += ["", "## Targets", ""] + target_lines(table, async_rows)
    (out / "RESULTS.md").write_text("\n".join(lines) + "\n")


def target_lines(table: list[dict], async_rows: list[dict]) -> list[str]:
    """Met/missed lines for the issue's targets, computed from the table."""
    lines = []
    for problem, noise in sorted({(r["problem"], r["noise"]) for r in table}):
        rows = {r["tool"]: r for r in table if r["problem"] == problem and r["noise"] == noise}
        ours = rows.get("demcal")
        peers = {tool: row for tool, row in rows.items() if not tool.startswith("demcal")}
        if ours is None or not peers:
            continue
        best_tool = min(peers, key=lambda tool: peers[tool]["median_regret"])
        best = peers[best_tool]["median_regret"]
        verdict = "met" if ours["median_regret"] <= best else "MISSED"
        lines.append(
            f"- {problem}, noise {noise}: demcal median regret {ours['median_regret']:.3g} vs best "
            f"peer {best_tool} {best:.3g}: {verdict}"
        )
        if "pysot_dycors" in peers:
            dycors = peers["pysot_dycors"]["median_regret"]
            verdict = "met" if ours["median_regret"] <= dycors else "MISSED"
            lines.append(f"  - not worse than pySOT DYCORS ({dycors:.3g}): {verdict}")
        if problem == "hartmann6":
            seconds = ours["median_s_per_proposal"]
            lines.append(
                f"  - seconds per proposal {seconds:.3g} < 0.5: "
                f"{'met' if seconds < 0.5 else 'MISSED'}"
            )
    for a in async_rows:
        lines.append(
            f"- P={a['workers']} speedup on {a['problem']}: {a['speedup']:.2f} >= 3: "
            f"{'met' if a['speedup'] >= 3 else 'MISSED'}"
        )
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seeds", type=int, default=10, help="number of seeds")
    parser.add_argument(
        "--first-seed", type=int, default=0, help="seeds are first-seed .. first-seed + seeds - 1"
    )
    parser.add_argument(
        "--problems", default="branin,hartmann6", help="comma-separated: branin, hartmann6"
    )
    parser.add_argument(
        "--tools", default=",".join(TOOLS), help=f"comma-separated subset of {', '.join(TOOLS)}"
    )
    parser.add_argument("--noise", default="none,2%", help="comma-separated: none, 2%%")
    parser.add_argument("--workers", type=int, default=4, help="P for the asynchronous run")
    parser.add_argument("--no-async", action="store_true", help="skip the asynchronous run")
    parser.add_argument(
        "--reuse",
        type=Path,
        help="earlier results.csv: its rows of tools not run now join the table "
        "(said in RESULTS.md)",
    )
    parser.add_argument(
        "--out", type=Path, default=HERE, help="folder for results.csv, async.csv, RESULTS.md"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    tools = [t for t in args.tools.split(",") if t]
    for tool in tools:
        if tool not in TOOLS:
            parser.error(f"unknown tool {tool!r}; choose from {', '.join(TOOLS)}")
    problems = [PROBLEMS[p] for p in args.problems.split(",") if p]
    noise_levels = [n == "2%" for n in args.noise.split(",") if n]
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    args.out.mkdir(parents=True, exist_ok=True)
    reused = []
    if args.reuse:
        with open(args.reuse, newline="") as handle:
            reused = [row for row in csv.DictReader(handle) if row["tool"] not in tools]
    for name in ("results.csv", "async.csv"):
        (args.out / name).unlink(missing_ok=True)
    command = "python benchmarks/optimizer/run_benchmark.py " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    started = time.perf_counter()
    rows = list(reused)
    with open(args.out / "results.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=RESULT_FIELDS)
        writer.writeheader()
        writer.writerows(reused)
        for problem in problems:
            for noisy in noise_levels:
                for tool in tools:
                    for seed in seeds:
                        row = one_run(tool, problem, noisy, seed)
                        rows.append(row)
                        writer.writerow(row)
                        handle.flush()
                        print(
                            f"{problem.name} noise={row['noise']} {tool} seed={seed}: regret "
                            f"{row['regret']:.3g} (best evaluated "
                            f"{row['best_evaluated_regret']:.3g}), "
                            f"{row['seconds_per_proposal']:.3f} s/proposal",
                            flush=True,
                        )
    async_rows = []
    if not args.no_async and "demcal" in tools:
        for problem in problems:
            async_rows.append(async_experiment(problem, seeds, args.workers, False, args.out))
            print(f"async {problem.name}: {async_rows[-1]}", flush=True)
    reused_tools = sorted({row["tool"] for row in reused})
    note = (
        f"Rows of {', '.join(reused_tools)} reused from {args.reuse} (an earlier run)."
        if reused
        else ""
    )
    write_report(
        summarise(rows), async_rows, command, args.out, time.perf_counter() - started, note
    )


if __name__ == "__main__":
    main()
