"""The advice against what happened, for every candidate, on the analytic engine (issue 39).

A study targets the analytic cylinder lift's angle of repose alone (spread 0.5 deg, the
engine's noise 0.5 %), so that sliding and rolling friction trade off along a curve. At each
truth: the calibration, ``demcal advise`` (the calibration device and the shear box: five
candidate responses), then one joint calibration per candidate, its added target valued at
the truth (mean of two seeds) with the advice's spread (``advise_lammps.joint_run``). Per
candidate and parameter: the advice's expected likely span against the span the joint
calibration reports (shares of the box), and whether the truth lies inside; per truth, the
rank correlation of the advice's scores with the realised mean spans. The analytic responses
are known, so the exact sets are too: every parameter set whose noise-free responses meet the
first target, and then both, within 2 band sd (a grid of ``GRID`` x ``GRID``), against which
the calibrations' and the advice's spans are read.

    python benchmarks/advise_analytic.py
    python benchmarks/advise_analytic.py --table   # the table again from the JSON and YAMLs

Works in advise-analytic/ and writes benchmarks/results/advise_analytic.json and .md.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
import yaml
from advise_lammps import RESULTS, demcal, joint_run, spans, spent, truth_means
from scipy.stats import spearmanr

from demcal.optimizer.bounds import from_unit_box
from demcal.optimizer.membership import BAND_SD, band_sd
from demcal.scenes import SCENES
from demcal.study.config import load_study_file

#: Grid points per parameter of the exact sets.
GRID = 201

#: The truths: on the low-rolling and the high-rolling part of the angle's curve.
TRUTHS = {
    "t1": {"sliding_friction_pp": 0.25, "rolling_friction_pp": 0.06},
    "t2": {"sliding_friction_pp": 0.15, "rolling_friction_pp": 0.2},
}
STUDY = {
    "engine": {"name": "analytic", "noise": 0.005},
    "parameters": {
        "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
        "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
    },
    "fixed": {"restitution_pp": 0.5},
    "targets": [
        {"scene": "cylinder_lift", "response": "angle_of_repose", "unit": "deg", "spread": 0.5}
    ],
    "replicates": 1,
    "seed": 5,
    "optimizer": {"max_evaluations": 16, "map_solutions": 8},
}


def one_truth(log: Path, tag: str, truth: dict[str, float]) -> dict:
    name = f"advise-analytic-{tag}"
    path = Path(f"{name}.yaml")
    config = {"study": name, **STUDY}
    config["targets"] = [dict(STUDY["targets"][0], value=1.0)]
    path.write_text(yaml.safe_dump(config, sort_keys=False))  # a value to load it by
    angle = truth_means(log, path, "cylinder_lift", truth, name)["angle_of_repose"]
    config["targets"][0]["value"] = float(f"{angle:.6g}")
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    demcal(log, "run", str(path))
    before = {**spans(log, name, truth), "spent": spent(name)}
    demcal(log, "advise", str(path))
    advice = json.loads(Path(f"results/{name}/advice/advice.json").read_text())
    joints = [
        joint_run(log, advice, entry, truth, name, f"r{rank}")
        for rank, entry in enumerate(advice["ranking"], 1)
    ]
    realised = [
        sum(j["parameters"][p]["share"] for p in advice["parameters"]) / len(advice["parameters"])
        for j in joints
    ]
    scores = [entry["score"] for entry in advice["ranking"]]
    return {
        "truth": truth,
        "target": config["targets"][0],
        "calibration": before,
        "joints": joints,
        "rank_correlation": float(spearmanr(scores, realised).statistic),
    }


def exact_shares(path: Path) -> tuple[dict[str, float], dict[str, float]]:
    """Each free parameter's span (share of its box) over the exact set of the joint study
    ``path``: under its first target alone, and under all of its targets."""
    study = load_study_file(path)
    axes = np.meshgrid(*[np.linspace(0.0, 1.0, GRID)] * len(study.free), indexing="ij")
    unit = np.column_stack([axis.ravel() for axis in axes])
    lower = np.array([p.lower for p in study.free])
    upper = np.array([p.upper for p in study.free])
    names = [p.name for p in study.free]
    inside = []
    for t in study.targets:
        scene = SCENES.load(t.scene)
        values = np.array(
            [
                scene.analytic_model(
                    study.parameters_for(dict(zip(names, map(float, row)))),
                    study.settings[t.scene],
                )[t.response]
                for row in from_unit_box(unit, lower, upper)
            ]
        )
        inside.append(np.abs(values - t.value) <= BAND_SD * band_sd(t, 0.0))

    def shares(mask: np.ndarray) -> dict[str, float]:
        return {n: float(np.ptp(unit[mask, i])) for i, n in enumerate(names)}

    return shares(inside[0]), shares(np.logical_and.reduce(inside))


def table(results: dict) -> str:
    lines = [
        "| truth | rank | added target | parameter | before | exact before | expected "
        "| realised | exact after | truth in |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for tag, result in results.items():
        before = result["calibration"]["parameters"]
        for rank, joint in enumerate(result["joints"], 1):
            for name, after in joint["parameters"].items():
                lines.append(
                    f"| {tag} | {rank} | {joint['test']} | {name} | "
                    f"{100 * before[name]['share']:.0f} % | "
                    f"{100 * joint['exact_before'][name]:.0f} % | "
                    f"{100 * joint['expected_share'][name]:.0f} % | "
                    f"{100 * after['share']:.0f} % | {100 * joint['exact_after'][name]:.0f} % | "
                    f"{'yes' if after['truth_inside'] else 'no'} |"
                )
    correlations = ", ".join(
        f"{tag} {result['rank_correlation']:+.2f}" for tag, result in results.items()
    )
    return "\n".join(
        [*lines, "", f"rank correlation of score and realised mean span: {correlations}"]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", action="store_true", help="the table again, no run")
    args = parser.parse_args()
    folder = Path("advise-analytic").resolve()
    folder.mkdir(exist_ok=True)
    os.chdir(folder)
    start = time.monotonic()
    log = folder / "benchmark.log"
    out = RESULTS / "advise_analytic"
    if args.table:
        results = json.loads(out.with_suffix(".json").read_text())
    else:
        results = {tag: one_truth(log, tag, truth) for tag, truth in TRUTHS.items()}
    for tag, result in results.items():
        for rank, joint in enumerate(result["joints"], 1):
            path = Path(f"advise-analytic-{tag}-{joint['test'].split('.')[0]}-r{rank}.yaml")
            joint["exact_before"], joint["exact_after"] = exact_shares(path)
    out.with_suffix(".json").write_text(json.dumps(results, indent=2))
    text = (
        f"{table(results)}\n\npython benchmarks/advise_analytic.py "
        f"(wall {(time.monotonic() - start) / 60:.0f} min)\n"
    )
    out.with_suffix(".md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
