"""Seconds per proposal of a response strategy at a given data size.

    python benchmarks/proposal_time.py [--dimension 7] [--points 100] [--responses 3]
                                       [--model kriging] [--window 20]

Tells a seeded synthetic problem (smooth responses of the parameters plus
2 % noise) to an ``Optimizer`` with ``response_ei`` until it holds
``points`` evaluations, one at a time, and times each ``ask`` of the last
``window`` proposals: the response models' refits (warm-started, with a full
refit every few as in demcal.optimizer.responses) and the candidate scoring.
Prints the median and the maximum. The issue's goal: under 2 s at 100
points in 7 dimensions.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from demcal.optimizer import Optimizer  # noqa: E402
from demcal.optimizer.objective import ResponseObjective, Target  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dimension", type=int, default=7)
    parser.add_argument("--points", type=int, default=100)
    parser.add_argument("--responses", type=int, default=3)
    parser.add_argument("--model", default="kriging", choices=("kriging", "cubic_rbf"))
    parser.add_argument("--window", type=int, default=20)
    args = parser.parse_args()
    d, rng = args.dimension, np.random.default_rng(0)
    targets = tuple(
        Target("scene", f"response{i}", 1.0 + i, spread=0.05) for i in range(args.responses)
    )
    directions = rng.normal(size=(args.responses, d))
    optimizer = Optimizer(
        [0.0] * d,
        [1.0] * d,
        {
            "strategy": "response_ei",
            "response_model": args.model,
            "max_evaluations": args.points + args.window,
        },
        seed=1,
        objective=ResponseObjective(targets),
    )

    def simulate(x: np.ndarray) -> dict[str, list[float]]:
        clean = [
            t.value + np.sin(directions[i] @ x) + 0.1 * float(x @ x) for i, t in enumerate(targets)
        ]
        return {
            t.key: [float(v * (1 + 0.02 * rng.standard_normal()))] for t, v in zip(targets, clean)
        }

    seconds = []
    while optimizer.completed_evaluations() < args.points + args.window // 2:
        start = time.perf_counter()
        proposal = optimizer.ask(1)[0]
        elapsed = time.perf_counter() - start
        if optimizer.completed_evaluations() >= args.points - args.window // 2:
            seconds.append(elapsed)
        optimizer.tell(proposal.id, responses=simulate(np.asarray(proposal.x)))
    print(
        f"{args.model}, {args.responses} responses, {d}-D, proposals at "
        f"{args.points - args.window // 2}-{args.points + args.window // 2} points: median "
        f"{statistics.median(seconds):.2f} s, max {max(seconds):.2f} s"
    )


if __name__ == "__main__":
    main()
