"""Asynchronous workers on the calibration problems: speedup at equal answer quality.

An event simulation of P workers (Samuelsson 2023, sec. 3.7 and 5.1.2):
each simulation of problems.py takes a random time, uniform on [0.5, 1.5]
units, and whenever one finishes the optimizer is told and asked for the
next point, so no worker waits for another. The optimizer is demcal's, with
its default strategy and the calibration benchmark's adapter (run.py).

Measured per problem and P, over the seeds:
- time to the noise level: the simulated time until the running answer
  (``opt.best()``) first has a true objective at or below the problem's
  noise level, and the simulations finished by then. Speedup at P = the
  median time at P = 1 over the median time at P: the wall-time gain at
  equal answer quality (an answer within noise);
- where the optimizer's own stop ("answer known") would have ended the
  run, and the true objective there;
- the true objective at the end of the budget;
- the optimizer's wall seconds per finished simulation: the tell, the best
  point, the stop rule and the next proposal, as demcal's daemon calls them;
  mean and largest.

Run from the repository root (any venv with demcal; the peers are not needed):

    OMP_NUM_THREADS=1 python benchmarks/calibration/workers.py --workers 1,4,8,16

Writes workers.csv (one row per run) and WORKERS.md to --out (default: this folder).
"""

from __future__ import annotations

import argparse
import csv
import heapq
import math
import platform
import statistics
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from problems import PROBLEMS, Problem, mean_responses  # noqa: E402
from run import demcal_revision, demcal_targets, make_demcal_optimizer, tell_demcal  # noqa: E402

DURATION_RANGE = (0.5, 1.5)  # simulated time units per simulation
FIELDS = [
    "problem",
    "workers",
    "seed",
    "budget",
    "simulations",
    "end_time",
    "time_to_noise",
    "simulations_to_noise",
    "stop_time",
    "stop_simulations",
    "stop_true_objective",
    "final_true_objective",
    "ask_seconds_mean",
    "ask_seconds_max",
]


def simulate(problem: Problem, workers: int, seed: int, budget: int) -> dict:
    """One run of ``workers`` asynchronous workers; see the module docstring."""
    from demcal.optimizer.objective import objective_value, replicate_objectives

    targets = demcal_targets(problem)
    opt = make_demcal_optimizer(problem, "response_ei", budget, seed, workers=workers)
    durations = np.random.default_rng([30_000, seed, workers])
    running: list[tuple[float, int, list[float]]] = []
    row: dict = {"problem": problem.name, "workers": workers, "seed": seed, "budget": budget}
    row.update(time_to_noise=math.inf, simulations_to_noise=math.inf)
    row.update(stop_time=math.inf, stop_simulations=math.inf, stop_true_objective=math.nan)

    def hand_out(count: int, now: float) -> int:
        """Ask for ``count`` points and start them; how many workers stay idle."""
        proposals = opt.ask(count)
        for proposal in proposals:
            duration = durations.uniform(*DURATION_RANGE)
            heapq.heappush(running, (now + duration, proposal.id, proposal.x))
        return count - len(proposals)

    idle = hand_out(workers, 0.0)
    finished, started, rounds, trace = 0, time.perf_counter(), [], []
    while running:
        now, ident, x = heapq.heappop(running)
        finished += 1
        responses = problem.noisy_responses(x, seed, ident)
        value = objective_value(targets, mean_responses(responses))
        clock = time.perf_counter()
        tell_demcal(opt, ident, responses, value, replicate_objectives(targets, responses))
        best = opt.best()
        reason = opt.stop_reason(time.perf_counter() - started)
        idle = hand_out(idle + 1, now)
        rounds.append(time.perf_counter() - clock)
        answer = problem.true_objective(best.x)
        trace.append((now, answer))
        if answer <= problem.noise_level and math.isinf(row["time_to_noise"]):
            row.update(time_to_noise=now, simulations_to_noise=finished)
        if reason and not reason.startswith("evaluation budget") and math.isinf(row["stop_time"]):
            row.update(stop_time=now, stop_simulations=finished, stop_true_objective=answer)
    row.update(
        simulations=finished,
        end_time=now,
        final_true_objective=problem.true_objective(opt.best().x),
        ask_seconds_mean=statistics.fmean(rounds),
        ask_seconds_max=max(rounds),
        trace=trace,
    )
    return row


def median(values: list[float]) -> float:
    return float(np.median(values)) if values else math.nan


def running_answer(trace: list[tuple[float, float]], moments: np.ndarray) -> np.ndarray:
    """The true objective of a run's running answer at each of ``moments`` (inf before its
    first answer)."""
    times = np.array([t for t, _ in trace])
    values = np.array([v for _, v in trace])
    index = np.searchsorted(times, moments, side="right") - 1
    return np.where(index >= 0, values[np.maximum(index, 0)], np.inf)


def time_to_quality(runs: list[dict], quality: float, moments: np.ndarray) -> float:
    """The first moment at which the median over ``runs`` of the running answer's true
    objective is at or below ``quality`` (inf if never)."""
    curve = np.median([running_answer(r["trace"], moments) for r in runs], axis=0)
    reached = np.nonzero(curve <= quality)[0]
    return float(moments[reached[0]]) if len(reached) else math.inf


def summarise(rows: list[dict]) -> list[dict]:
    """Per problem and P: medians over the seeds, and the speedups against P = 1."""
    table = []
    for name in dict.fromkeys(r["problem"] for r in rows):
        serial = [r for r in rows if r["problem"] == name and r["workers"] == 1]
        serial_time = median([r["time_to_noise"] for r in serial])
        serial_end = median([r["end_time"] for r in serial])
        moments = np.linspace(0.0, max(r["end_time"] for r in serial), 2000)
        for workers in sorted({r["workers"] for r in rows if r["problem"] == name}):
            runs = [r for r in rows if r["problem"] == name and r["workers"] == workers]
            to_noise = median([r["time_to_noise"] for r in runs])
            end = median([r["end_time"] for r in runs])
            stopped = [r for r in runs if math.isfinite(r["stop_time"])]
            final = median([r["final_true_objective"] for r in runs])
            # equal quality: the worse of the serial and the parallel runs' final medians
            quality = max(final, median([r["final_true_objective"] for r in serial]))
            table.append(
                {
                    "problem": name,
                    "workers": workers,
                    "runs": len(runs),
                    "reached": sum(math.isfinite(r["time_to_noise"]) for r in runs),
                    "time_to_noise": to_noise,
                    "simulations_to_noise": median([r["simulations_to_noise"] for r in runs]),
                    "speedup": serial_time / to_noise if serial else math.nan,
                    "quality": quality,
                    "quality_speedup": time_to_quality(serial, quality, moments)
                    / time_to_quality(runs, quality, moments),
                    "budget_speedup": serial_end / end if serial else math.nan,
                    "stopped": len(stopped),
                    "stop_time": median([r["stop_time"] for r in stopped]),
                    "stop_true_objective": median([r["stop_true_objective"] for r in stopped]),
                    "final_true_objective": final,
                    "ask_seconds_mean": median([r["ask_seconds_mean"] for r in runs]),
                    "ask_seconds_max": max(r["ask_seconds_max"] for r in runs),
                }
            )
    return table


def report(table: list[dict], command: str, minutes: float, budget: int) -> str:
    lines = [
        "# Asynchronous workers on the calibration problems",
        "",
        f"Command: `{command}`",
        "",
        f"Date: {datetime.now(UTC):%Y-%m-%d %H:%M} UTC; total {minutes:.1f} min. demcal at "
        f"{demcal_revision()}; machine {platform.machine()}, Python "
        f"{platform.python_version()}. Written by workers.py.",
        "",
        f"Budget {budget} simulations per run; durations uniform on {DURATION_RANGE} units. "
        "Time to noise: median simulated time until the running answer's true objective is "
        "at or below the noise level (inf: half the runs or more never got there). Speedup: "
        "the median time to noise at P = 1 over that at P (goal: >= 0.85 P up to 8, "
        ">= 0.7 P at 16). Budget speedup: the same for the time to finish the budget (the "
        "thesis' Figure 5.4b). Stop: where demcal's stop rule (answer known) would have ended "
        "the run. s/ask: the optimizer's wall seconds per finished simulation "
        "(tell, best point, stop rule, next proposal), median of the runs' means, and the "
        "largest single one.",
        "",
        "| problem | P | runs | reached noise | time to noise | sims to noise | speedup "
        "| speedup / P | final-quality speedup / P | budget speedup | stopped | stop time "
        "| true objective at stop | final true objective | s/ask mean | s/ask max |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table:
        lines.append(
            f"| {r['problem']} | {r['workers']} | {r['runs']} | {r['reached']}/{r['runs']} "
            f"| {r['time_to_noise']:.2f} | {r['simulations_to_noise']:.1f} "
            f"| {r['speedup']:.2f} | {r['speedup'] / r['workers']:.2f} "
            f"| {r['quality_speedup'] / r['workers']:.2f} "
            f"| {r['budget_speedup']:.2f} | {r['stopped']}/{r['runs']} | {r['stop_time']:.2f} "
            f"| {r['stop_true_objective']:.3g} | {r['final_true_objective']:.3g} "
            f"| {r['ask_seconds_mean']:.3f} | {r['ask_seconds_max']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", default=",".join(PROBLEMS))
    parser.add_argument("--workers", default="1,4,8,16", help="comma-separated P values")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--budget", type=int, default=40)
    parser.add_argument("--out", type=Path, default=HERE)
    args = parser.parse_args(argv)
    workers = sorted({int(p) for p in args.workers.split(",")} | {1})
    started = time.perf_counter()
    rows = []
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "workers.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, FIELDS, extrasaction="ignore")
        writer.writeheader()
        for name in args.problems.split(","):
            for p in workers:
                for seed in range(args.seeds):
                    row = simulate(PROBLEMS[name], p, seed, args.budget)
                    rows.append(row)
                    writer.writerow(row)
                    handle.flush()
                    print(
                        f"{name} P={p} seed={seed}: noise at t={row['time_to_noise']:.2f} "
                        f"({row['simulations_to_noise']} sims), final "
                        f"{row['final_true_objective']:.3g}, ask {row['ask_seconds_mean']:.3f} s",
                        flush=True,
                    )
    command = "python benchmarks/calibration/workers.py " + " ".join(argv or sys.argv[1:])
    text = report(
        summarise(rows), command.strip(), (time.perf_counter() - started) / 60, args.budget
    )
    (args.out / "WORKERS.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
