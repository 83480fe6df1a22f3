"""The advice against what happened, for every candidate, on the analytic engine (issue 39).

A study targets the analytic cylinder lift's angle of repose alone (spread 0.5 deg, the
engine's noise 0.5 %), so that sliding and rolling friction trade off along a curve. At each
truth: the calibration, ``demcal advise`` (the calibration device and the shear box: five
candidate responses), then one joint calibration per candidate, its added target valued at
the truth (mean of two seeds) with the advice's spread (``advise_lammps.joint_run``). Per
candidate and parameter: the advice's expected likely span against the span the joint
calibration reports (shares of the box), and whether the truth lies inside; per truth, the
rank correlation of the advice's scores with the realised mean spans.

    python benchmarks/advise_analytic.py

Works in advise-analytic/ and writes benchmarks/results/advise_analytic.json and .md.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import yaml
from advise_lammps import RESULTS, demcal, joint_run, spans, spent, truth_means
from scipy.stats import spearmanr

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


def table(results: dict) -> str:
    lines = [
        "| truth | rank | added target | parameter | before | expected | realised | truth in |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for tag, result in results.items():
        before = result["calibration"]["parameters"]
        for rank, joint in enumerate(result["joints"], 1):
            for name, after in joint["parameters"].items():
                lines.append(
                    f"| {tag} | {rank} | {joint['test']} | {name} | "
                    f"{100 * before[name]['share']:.0f} % | "
                    f"{100 * joint['expected_share'][name]:.0f} % | "
                    f"{100 * after['share']:.0f} % | {'yes' if after['truth_inside'] else 'no'} |"
                )
    correlations = ", ".join(
        f"{tag} {result['rank_correlation']:+.2f}" for tag, result in results.items()
    )
    return "\n".join(
        [*lines, "", f"rank correlation of score and realised mean span: {correlations}"]
    )


def main() -> None:
    folder = Path("advise-analytic").resolve()
    folder.mkdir(exist_ok=True)
    os.chdir(folder)
    start = time.monotonic()
    log = folder / "benchmark.log"
    results = {tag: one_truth(log, tag, truth) for tag, truth in TRUTHS.items()}
    out = RESULTS / "advise_analytic"
    out.with_suffix(".json").write_text(json.dumps(results, indent=2))
    text = (
        f"{table(results)}\n\npython benchmarks/advise_analytic.py "
        f"(wall {(time.monotonic() - start) / 60:.0f} min)\n"
    )
    out.with_suffix(".md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
