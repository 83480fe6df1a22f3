"""The flows of a chute design study's answer over its saved runs (Samuelsson 2023, Fig. 5.5b).

    python benchmarks/chute_answer.py results/chute [--figure answer_over_time.png]

Prints the left and right mass flows, their difference and the split over the steady
window of the answer's own run and of its confirmation runs (mean ± sd), from the delivered
masses each run kept, and draws the report's figure of the flows over time.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from demcal.errors import DemcalError
from demcal.reporting.figures import answer_runs, plot_answer_history
from demcal.results.records import BestRecord, SimulationRecord
from demcal.scenes.transfer_chute.lammps import flow_responses, window_rate
from demcal.study.model import load_frozen

SCENE = "transfer_chute"


def run_flows(study, evaluation: str, replicate: int) -> dict[str, float] | None:
    """The four flow responses of one replicate of an evaluation, or None if it kept no
    state."""
    files = study.files.evaluation(evaluation).replicate(SCENE, replicate)
    try:
        settings = SimulationRecord.read(files.simulation).settings
        with np.load(files.state) as state:
            times = np.asarray(state["delivery_time"], float)
            window = (settings["steady_from"], settings["feed_time"])
            left = window_rate(times, np.asarray(state["delivered_left"], float), *window)
            right = window_rate(times, np.asarray(state["delivered_right"], float), *window)
    except (DemcalError, OSError, KeyError, ValueError):
        return None
    return flow_responses(left, right)


def summary(runs: list[dict[str, float]]) -> str:
    """One line per response: mean ± sd over the runs."""
    lines = []
    for response in runs[0]:
        values = np.array([run[response] for run in runs])
        sd = values.std(ddof=1) if len(values) > 1 else float("nan")
        lines.append(f"  {response:16s} {values.mean():9.3f} ± {sd:.3f}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the study's results folder")
    parser.add_argument("--figure", type=Path, help="also draw the flows over time here")
    args = parser.parse_args()
    study = load_frozen(args.folder / "study.json")
    best = BestRecord.read(study.files.best)
    evaluations = answer_runs(study, best)
    flows = {(e, r): run_flows(study, e, r) for e in evaluations for r in range(study.replicates)}
    kept = {run: f for run, f in flows.items() if f is not None}
    print(f"answer {best.evaluation}: {best.parameters}")
    print(f"runs with a saved state: {', '.join(f'{e}/rep{r}' for e, r in kept) or 'none'}")
    confirmations = [f for (e, _), f in kept.items() if e != best.evaluation]
    if confirmations:
        print(f"the {len(confirmations)} confirmations [kg/s; split: left share]:")
        print(summary(confirmations))
    if len(kept) > len(confirmations):
        print(f"with the answer's own run, {len(kept)} runs:")
        print(summary(list(kept.values())))
    if args.figure:
        plot_answer_history(study, best, args.figure)
        print(f"figure: {args.figure}")


if __name__ == "__main__":
    main()
