"""Which lab test next, checked on LAMMPS against a known truth (issue 39).

For one synthetic truth of the quickstart's material (sliding and rolling friction):

1. the targets: the cylinder lift's angle of repose and bulk density at the truth, the mean of
   two seeds (``benchmarks/scene_noise.py``), with the quickstart's spreads;
2. the calibration on them, as the README's study runs (``demcal run``);
3. ``demcal advise``, every candidate lab test;
4. the joint calibration with the top-ranked test's response as the added target, its value
   the mean of two seeds at the truth, through the joint study file the advice wrote; and the
   same with the lowest-ranked response, to show whether the ranking matters.

Per parameter: the likely span before and after each joint calibration (share of its box),
the advice's expected span, whether the truth lies inside each set, and the simulations and
CPU each step spent. Run from the repository root, one truth per run:

    OMP_NUM_THREADS=1 python benchmarks/advise_lammps.py a \\
        --truth sliding_friction_pp=0.3 rolling_friction_pp=0.06
    OMP_NUM_THREADS=1 python benchmarks/advise_lammps.py b \\
        --truth sliding_friction_pp=0.5 rolling_friction_pp=0.15

Works in advise-<tag>/ (a run resumes there: demcal resumes every study) and writes
benchmarks/results/advise_lammps_<tag>.json and .md (the table, the command, the times).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import yaml

from demcal.scenes import SCENES

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
BASE = ROOT / "config" / "config.yaml"
#: Seeds of each synthetic target at the truth.
TRUTH_SEEDS = 2


def run(log: Path, *command: str) -> str:
    """Run ``command``, its output appended to ``log``; stop the benchmark if it fails."""
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    with log.open("a") as out:
        out.write(f"$ {' '.join(command)}\n{done.stdout}{done.stderr}\n")
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed (see {log}):\n{done.stderr[-3000:]}")
    return done.stdout


def demcal(log: Path, *words: str) -> str:
    return run(log, sys.executable, "-m", "demcal.cli", *words)


def truth_means(log: Path, config: Path, scene: str, truth: dict[str, float], tag: str) -> dict:
    """The mean of TRUTH_SEEDS seeds of every targeted response of ``scene`` at ``truth`` (run
    once: the noise file of an earlier run is read again)."""
    study = yaml.safe_load(config.read_text())["study"]
    found = RESULTS / f"noise_{study}_{scene}_{tag}.json"
    if not found.exists():
        point = [f"{name}={value}" for name, value in truth.items()]
        script = str(ROOT / "benchmarks" / "scene_noise.py")
        run(log, sys.executable, script, str(config), "--scene", scene, "--seeds",
            str(TRUTH_SEEDS), "--point", *point, "--tag", tag)  # fmt: skip
    runs = json.loads(found.read_text())["runs"]
    ok = [r for r in runs if r["status"] == "ok"]
    if len(ok) < TRUTH_SEEDS:
        raise SystemExit(f"{scene} at the truth: {len(ok)} of {len(runs)} runs ok")
    names = [name for name in SCENES.load(scene).responses if name in ok[0]]
    return {name: sum(r[name] for r in ok) / len(ok) for name in names}


def spans(log: Path, study: str, truth: dict[str, float]) -> dict:
    """The verdicts of ``demcal solutions`` on a finished study, and whether the truth lies in
    each likely span and in the set (``--point``)."""
    demcal(log, "solutions", study)
    summary = json.loads(Path(f"results/{study}/solutions.json").read_text())
    point = [f"{name}={value}" for name, value in truth.items()]
    check = demcal(log, "solutions", study, "--point", *point).splitlines()[0]
    return {
        "likely_sets": summary["likely"],
        "truth_check": check,
        "parameters": {
            v["name"]: {
                "low": v["low"],
                "high": v["high"],
                "share": v["share"],
                "verdict": v["verdict"],
                "truth_inside": v["low"] <= truth[v["name"]] <= v["high"],
            }
            for v in summary["verdicts"]
        },
    }


def spent(study: str) -> dict:
    """The new simulations (evaluations x scenes x replicates, reused points left out) and the
    CPU seconds a study spent."""
    table = pd.read_csv(f"results/{study}/evaluations.csv")
    table = table[~table["origin"].isin(["archive", "neighbouring material"])]
    frozen = json.loads(Path(f"results/{study}/study.json").read_text())
    per_evaluation = len(frozen["scenes"]) * frozen["replicates"]
    cpu = pd.to_numeric(table["cpu_s"], errors="coerce").fillna(0.0)
    return {"simulations": int(len(table) * per_evaluation), "cpu_s": float(cpu.sum())}


def campaign_spent(folder: Path) -> dict:
    """The simulations and CPU seconds of a campaign's study folder (the advice's)."""
    count, cpu = 0, 0.0
    for path in folder.glob("evals/*/*/rep*/responses.json"):
        record = json.loads(path.read_text())
        count += 1
        cpu += float((record.get("cost") or {}).get("cpu_s") or 0.0)
    return {"simulations": count, "cpu_s": cpu}


def joint_run(log: Path, advice: dict, entry: dict, truth: dict, tag: str, label: str) -> dict:
    """The joint calibration with ``entry``'s response as the added target, valued at the
    truth: the advice's joint study file of its test, its added target set to this response."""
    scene_file = next(
        r["joint_study"]
        for r in advice["ranking"]
        if r["scene"] == entry["scene"] and r["joint_study"]
    )
    joint = yaml.safe_load(Path(scene_file).read_text())
    name = f"{joint['study']}-{label}"
    joint["study"] = name
    added = joint["targets"][-1]
    added.update(response=entry["response"], unit=entry["unit"], spread=entry["spread"], value=1.0)
    path = Path(f"{name}.yaml")
    path.write_text(yaml.safe_dump(joint, sort_keys=False))  # a value to load it by
    means = truth_means(log, path, entry["scene"], truth, f"{tag}-{label}")
    added["value"] = float(f"{means[entry['response']]:.6g}")
    path.write_text(yaml.safe_dump(joint, sort_keys=False))
    demcal(log, "run", str(path))
    return {
        "test": f"{entry['scene']}.{entry['response']}",
        "value": added["value"],
        "spread": entry["spread"],
        "expected_share": entry["expected_share"],
        **spans(log, name, truth),
        "spent": spent(name),
    }


def table(result: dict) -> str:
    """The figures as a markdown table, one row per free parameter."""
    rows = [
        "| parameter | before | top: expected | top: after | truth in (before/top/lowest) "
        "| lowest: expected | lowest: after |",
        "|---|---|---|---|---|---|---|",
    ]
    before, top, low = result["calibration"], result["top"], result["lowest"]
    for name, b in before["parameters"].items():
        t, w = top["parameters"][name], low["parameters"][name]
        rows.append(
            f"| {name} | {b['low']:.3g}–{b['high']:.3g} ({100 * b['share']:.0f} %) | "
            f"{100 * top['expected_share'][name]:.0f} % | "
            f"{t['low']:.3g}–{t['high']:.3g} ({100 * t['share']:.0f} %) | "
            f"{'yes' if b['truth_inside'] else 'no'}/{'yes' if t['truth_inside'] else 'no'}/"
            f"{'yes' if w['truth_inside'] else 'no'} | "
            f"{100 * low['expected_share'][name]:.0f} % | "
            f"{w['low']:.3g}–{w['high']:.3g} ({100 * w['share']:.0f} %) |"
        )
    costs = ", ".join(
        f"{step} {result[step]['spent']['simulations']} simulations "
        f"({result[step]['spent']['cpu_s'] / 60:.0f} min CPU)"
        for step in ("calibration", "advice", "top", "lowest")
    )
    return "\n".join(
        [
            f"truth {result['truth']}; top-ranked {top['test']}, lowest-ranked {low['test']}",
            "",
            *rows,
            "",
            f"spent: {costs}",
        ]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tag", help="names the truth's folder and files")
    parser.add_argument("--truth", nargs="+", required=True, metavar="NAME=VALUE")
    args = parser.parse_args()
    truth = {w.split("=")[0]: float(w.split("=")[1]) for w in args.truth}
    folder = Path(f"advise-{args.tag}").resolve()
    folder.mkdir(exist_ok=True)
    command = " ".join(["python benchmarks/advise_lammps.py", args.tag, "--truth", *args.truth])
    os.chdir(folder)
    log = folder / "benchmark.log"
    start = time.monotonic()
    base = yaml.safe_load(BASE.read_text())
    name = f"advise-{args.tag}"
    base["study"] = name
    means = truth_means(log, BASE, "cylinder_lift", truth, f"advise-{args.tag}")
    for target in base["targets"]:
        target["value"] = float(f"{means[target['response']]:.6g}")
    study = folder / f"{name}.yaml"
    study.write_text(yaml.safe_dump(base, sort_keys=False))
    demcal(log, "run", str(study))
    result: dict = {"command": command, "truth": truth, "targets": base["targets"]}
    result["calibration"] = {**spans(log, name, truth), "spent": spent(name)}
    demcal(log, "advise", str(study))
    advice = json.loads(Path(f"results/{name}/advice/advice.json").read_text())
    result["advice"] = {
        "ranking": [
            {key: r[key] for key in ("scene", "response", "unit", "spread", "score")}
            | {"expected_share": r["expected_share"], "share_now": r["share_now"]}
            for r in advice["ranking"]
        ],
        "spent": {
            key: sum(campaign_spent(path)[key] for path in Path("results").glob(f"{name}-advice*"))
            for key in ("simulations", "cpu_s")
        },
    }
    result["top"] = joint_run(log, advice, advice["ranking"][0], truth, args.tag, "top")
    result["lowest"] = joint_run(log, advice, advice["ranking"][-1], truth, args.tag, "lowest")
    result["wall_s"] = time.monotonic() - start
    out = RESULTS / f"advise_lammps_{args.tag}"
    out.with_suffix(".json").write_text(json.dumps(result, indent=2))
    text = f"{table(result)}\n\n{command} (wall {result['wall_s'] / 60:.0f} min)\n"
    out.with_suffix(".md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
