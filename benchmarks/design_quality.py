"""Space filling of the campaign designs (Richter & Will 2021, Figs. 7-8): minimum inter-site
distance (larger is better) and cover measure (smaller is better) in the unit box.

    python benchmarks/design_quality.py [--size 160] [--dimensions 2 7 10] [--repeats 10]

Each design is drawn ``--repeats`` times with seeds 0, 1, ...; the table gives the mean and
the range. Seconds, no simulation.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from demcal.optimizer.designs import cover_measure, minimum_pairwise_distance
from demcal.optimizer.registry import DESIGNS

KINDS = ("fssf_f", "sobol", "halton", "latin_hypercube")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=160)
    parser.add_argument("--dimensions", type=int, nargs="+", default=[2, 7, 10])
    parser.add_argument("--repeats", type=int, default=10)
    args = parser.parse_args()
    print("| d | design | min. inter-site distance | cover measure | s per design |")
    print("|---|---|---|---|---|")
    for dimension in args.dimensions:
        for kind in KINDS:
            generate = DESIGNS[kind].load()
            distances, covers, start = [], [], time.monotonic()
            for seed in range(args.repeats):
                points = generate(args.size, dimension, np.random.default_rng(seed))
                distances.append(minimum_pairwise_distance(points))
                covers.append(cover_measure(points))
            seconds = (time.monotonic() - start) / args.repeats
            print(
                f"| {dimension} | {kind} | {np.mean(distances):.3f} "
                f"({min(distances):.3f}-{max(distances):.3f}) | {np.mean(covers):.3f} "
                f"({min(covers):.3f}-{max(covers):.3f}) | {seconds:.2f} |"
            )


if __name__ == "__main__":
    main()
