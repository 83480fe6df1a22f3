"""Richter & Will's (2021) metamodel-based global calibration on the shear box, at this
machine's scale: validation R² of the global models, three materials calibrated with no
simulation and checked by simulation, the same materials calibrated from scratch, and the
break-even.

    python benchmarks/global_calibration.py [--domain config/examples/shear_box_domain.yaml]
        [--holdout shear-box-domain-check] [--materials 3] [--repeats 3] [--validate 3]
        [--scratch-budget 20] [--steps scratch global]

Run it in the folder where the campaigns ran (their archive, results/archive.sqlite):

    demcal sample config/examples/shear_box_domain.yaml --n 160
    demcal sample config/examples/shear_box_domain.yaml --n 30 --design latin_hypercube \\
        --name shear-box-domain-check

The materials are made first, whatever the steps (their repeats run once and are kept); then
the steps (a finished calibration is kept and not run again):

0. Materials: points of the held-out campaign (parameters known, responses
   simulated), taken in order. Each truth is simulated ``--repeats`` more times
   (benchmarks/scene_noise.py); its targets are the means of all its runs, their spreads the
   seed-to-seed sd of the shear box (benchmarks/results/noise_shear-box_shear_box.json). Its
   PSD (d50, sigma_ln) is given, the other parameters are fixed at its values as if measured,
   except sliding friction particle-particle and particle density, which are free (Richter &
   Will, Tables 4 and 5).
1. ``scratch``: each material calibrated from scratch by ``demcal run`` (the default
   strategy, 2 workers, ``--scratch-budget`` evaluations): the simulations and CPU until the
   first one within both spreads.
2. ``global``: ``demcal metamodel build`` (Kriging and symbolic regression) without the
   held-out campaign and the materials' own simulations (gravel's too), and ``demcal
   metamodel validate`` on the campaign, beside a gradient-boosting baseline; then
   ``demcal calibrate-metamodel --validate N`` of each material on each model kind, and of
   gravel 8/16 as Richter & Will calibrate it (one validation run): its PSD from ``demcal
   psd fit`` of the shipped sieve file, their measured wall friction (0.363) and targets
   (35.53 deg, 1478.8 kg/m^3, Table 3), restitution 0.6 (Table 4), rolling friction 0.1 (the
   shear box example's: LAMMPS' rolling model is not theirs); sliding friction and density
   free.

Prints the tables of benchmarks/README.md, "Global calibration (issue 22)"; writes the
commands' output to benchmarks/results/global_calibration_output.txt and the figures to
benchmarks/results/global_calibration.json.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import subprocess
import sys
from pathlib import Path

import yaml

from demcal.archive.store import Archive
from demcal.study.config import load_study_file
from demcal.study.study_file import read_study_yaml

ROOT = Path(__file__).resolve().parents[1]
NOISE = ROOT / "benchmarks" / "results" / "noise_shear-box_shear_box.json"
#: Free in every material, as in Richter & Will's Table 5; the rest is held at the truth.
CALIBRATED = ("sliding_friction_pp", "particle_density")


def demcal(*args: str, log: list[str]) -> str:
    """Run one demcal command; its output (also kept in ``log``)."""
    command = [sys.executable, "-m", "demcal.cli", *args]
    done = subprocess.run(command, capture_output=True, text=True)
    text = f"$ demcal {' '.join(args)}\n{done.stdout}{done.stderr}"
    log.append(text)
    print(text, flush=True)
    if done.returncode != 0:
        raise SystemExit(f"demcal {args[0]} failed")
    return done.stdout


def spreads() -> dict[str, float]:
    """Seed-to-seed sd of each shear-box response, from the noise benchmark's runs."""
    runs = [r for r in json.loads(NOISE.read_text())["runs"] if r["status"] == "ok"]
    out = {}
    for name in ("shear_angle", "bulk_density"):
        values = [r[name] for r in runs]
        mean = sum(values) / len(values)
        out[name] = (sum((v - mean) ** 2 for v in values) / (len(values) - 1)) ** 0.5
    return out


def material_config(
    domain: dict, record, name: str, targets: dict[str, float], sd: dict[str, float]
) -> dict:
    """The study file of one material: ``targets`` (its truth's mean responses) with the
    shear box's spreads, its PSD, and the parameters not in CALIBRATED held at the truth."""
    config = {key: value for key, value in domain.items() if key != "parameters"}
    config["study"] = name
    scene = next(iter(domain["scenes"]))
    settings = dict(domain["scenes"][scene].get("settings", {}))
    settings.update(
        d50=record.parameters["d50"].value, sigma_ln=record.parameters["sigma_ln"].value
    )
    config["scenes"] = {scene: {"settings": settings}}
    config["parameters"] = {n: domain["parameters"][n] for n in CALIBRATED}
    held = {
        n: record.parameters[n].value
        for n in domain["parameters"]
        if n not in CALIBRATED and n not in settings
    }
    config["fixed"] = {**domain.get("fixed", {}), **held}
    config["targets"] = [
        {"scene": scene, "response": response, "value": value, "spread": sd[response]}
        for response, value in targets.items()
    ]
    return config


def gravel_config(domain: dict, log: list[str], sd: dict[str, float]) -> dict:
    """Gravel 8/16 (Richter & Will 2021, Tables 3-4) with the PSD of ``demcal psd fit``."""
    fit = demcal("psd", "fit", str(ROOT / "config/examples/sieve_gravel_8_16.csv"), log=log)
    psd = {
        line.split(":")[0]: float(line.split(":")[1].split("#")[0])
        for line in fit.splitlines()
        if line.startswith(("d50:", "sigma_ln:"))
    }
    config = {key: value for key, value in domain.items() if key != "parameters"}
    scene = next(iter(domain["scenes"]))
    config["study"] = "gravel-8-16"
    config["scenes"] = {scene: {"settings": {**domain["scenes"][scene]["settings"], **psd}}}
    config["parameters"] = {n: domain["parameters"][n] for n in CALIBRATED}
    config["fixed"] = {
        **domain.get("fixed", {}),
        "sliding_friction_pw": 0.363,
        "restitution_pp": 0.6,
        "rolling_friction_pp": 0.1,
    }
    config["targets"] = [
        {"scene": scene, "response": "shear_angle", "value": 35.53, "spread": sd["shear_angle"]},
        {"scene": scene, "response": "bulk_density", "value": 1478.8, "spread": sd["bulk_density"]},
    ]
    return config


def truth_runs(path: Path, record, repeats: int) -> list[dict[str, float]]:
    """The responses of every run of a material's truth: its campaign run and ``repeats``
    more with seeds of their own (benchmarks/scene_noise.py, run once and kept)."""
    config = yaml.safe_load(path.read_text())
    out = ROOT / "benchmarks" / "results" / f"noise_{config['study']}_shear_box_truth.json"
    if not out.exists():
        point = [f"{n}={record.parameters[n].value!r}" for n in CALIBRATED]
        subprocess.run(
            [
                sys.executable,
                str(ROOT / "benchmarks" / "scene_noise.py"),
                str(path),
                "--seeds",
                str(repeats),
                "--jobs",
                "1",
                "--point",
                *point,
                "--tag",
                "truth",
            ],
            check=True,
        )
    runs = [r for r in json.loads(out.read_text())["runs"] if r["status"] == "ok"]
    first = {name: quantity.value for name, quantity in record.responses.items()}
    return [first, *({name: r[name] for name in first} for r in runs)]


def within(row: dict, targets: dict[str, float], sd: dict[str, float]) -> bool:
    return row["status"] == "ok" and all(
        abs(float(row[f"shear_box.{name}"]) - value) <= sd[name] for name, value in targets.items()
    )


def scratch(config: dict, path: Path, budget: int, log: list[str]) -> dict:
    """A material calibrated from scratch by demcal's optimizer (default strategy, 2 workers):
    evaluations and CPU in all, and until the first evaluation within both spreads."""
    study = config["study"]
    config = {**config, "optimizer": {"max_evaluations": budget}, "calibration": {"workers": 2}}
    path.write_text(yaml.safe_dump(config))
    folder = Path("results") / study
    if not (folder / "finished.json").exists():
        demcal("run", str(path), log=log)
    with open(folder / "evaluations.csv", newline="") as handle:
        rows = sorted(csv.DictReader(handle), key=lambda row: row["evaluation"])
    targets = {t["response"]: t["value"] for t in config["targets"]}
    sd = {t["response"]: t["spread"] for t in config["targets"]}
    cpu = [float(row["cpu_s"] or 0.0) for row in rows]
    first = next((i for i, row in enumerate(rows) if within(row, targets, sd)), None)
    best = json.loads((folder / "best.json").read_text())
    return {
        "best": best["parameters"],
        "evaluations": len(rows),
        "cpu_s": sum(cpu),
        "first_within": None if first is None else first + 1,
        "cpu_to_first_within_s": None if first is None else sum(cpu[: first + 1]),
    }


def calibrate_on_both(
    material: Path, domain: str, validate: int, log: list[str]
) -> dict[str, dict]:
    """The material calibrated on the Kriging and on the symbolic models, each answer checked
    by ``validate`` simulations; each command's summary (metamodel/<kind>/calibration.json)
    with the validation runs' CPU seconds from the archive."""
    name = yaml.safe_load(material.read_text())["study"]
    out = {}
    for kind in ("kriging", "symbolic"):
        demcal(
            "calibrate-metamodel",
            str(material),
            "--domain",
            domain,
            "--model",
            kind,
            "--validate",
            str(validate),
            log=log,
        )
        out[kind] = json.loads(
            (Path("results") / name / "metamodel" / kind / "calibration.json").read_text()
        )
        runs = (Path("results") / name / "evals").glob(f"validate-{kind}-*/*/rep*/simulation.json")
        out[kind]["validation_cpu_s"] = [json.loads(r.read_text())["cost"]["cpu_s"] for r in runs]
    return out


def gradient_boosting_r2(domain, holdout: str, exclude: list[str]) -> dict[str, float]:
    """Held-out R² of a gradient-boosting baseline (scikit-learn's defaults, seeded) on the same
    training and held-out simulations as the global models: whether it would help."""
    from sklearn.ensemble import GradientBoostingRegressor

    from demcal.domain.metamodel import domain_data
    from demcal.optimizer.bounds import to_unit_box

    with Archive(domain.archive) as archive:
        train = domain_data(domain, archive, exclude=(holdout, *exclude))
        test = domain_data(domain, archive, only=(holdout,))
    scores = {}
    for key, rows in train.responses.items():
        model = GradientBoostingRegressor(random_state=1)
        model.fit(to_unit_box(rows.x, train.lower, train.upper), rows.y)
        held = test.responses[key]
        predicted = model.predict(to_unit_box(held.x, train.lower, train.upper))
        total = float(((held.y - held.y.mean()) ** 2).sum())
        scores[key] = 1.0 - float(((held.y - predicted) ** 2).sum()) / total
    return scores


def campaign_cpu(url: str, study: str) -> tuple[int, float]:
    """Simulations and CPU seconds of a campaign, from the archive."""
    with Archive(url) as archive:
        records = archive.records(study=study)
    return len(records), sum(float(r.cost.get("cpu_s", 0.0)) for r in records)


def material_rows(name: str, truth: dict, result: dict) -> list[str]:
    """The README table's rows of one material: per model kind, the answer, whether the
    solution set holds the truth, and the validation's errors against the targets."""
    rows = []
    for kind, summary in result["global"].items():
        answer = summary["optima"][0]["values"]
        spans = {v["name"]: v for v in summary["solution_set"]["verdicts"]}
        held = "no set" if not summary["solution_set"]["likely"] else "no"  # the spans, a box
        if held == "no" and all(spans[n]["low"] <= truth[n] <= spans[n]["high"] for n in spans):
            held = "yes"
        words = "; ".join(f"{n}: {spans[n]['verdict']}" for n in CALIBRATED if n in spans)
        errors = summary["validation"] or {}
        cells = [
            f"{100 * errors[k]['error_against_target']:+.2f} %" if k in errors else "-"
            for k in ("shear_box.shear_angle", "shear_box.bulk_density")
        ]
        rows.append(
            f"| {name} | {kind} | {answer['sliding_friction_pp']:.3f}, "
            f"{answer['particle_density']:.0f} | {words} | {held} | "
            f"{cells[0]} | {cells[1]} |"
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--domain", default=str(ROOT / "config/examples/shear_box_domain.yaml"))
    parser.add_argument("--holdout", default="shear-box-domain-check")
    parser.add_argument("--materials", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--validate", type=int, default=3)
    parser.add_argument("--scratch-budget", type=int, default=20)
    parser.add_argument("--steps", nargs="+", default=list(STEPS), choices=STEPS)
    args = parser.parse_args()
    log: list[str] = []
    domain = load_study_file(args.domain)
    with Archive(domain.archive) as archive:
        held_out = [
            r for r in archive.records(study=args.holdout, statuses=["ok"]) if len(r.responses) == 2
        ][: args.materials]
    sd = spreads()
    domain_yaml = read_study_yaml(args.domain)
    folder = ROOT / "benchmarks" / "results" / "global_materials"
    folder.mkdir(exist_ok=True)
    figures_path = ROOT / "benchmarks" / "results" / "global_calibration.json"
    figures = json.loads(figures_path.read_text()) if figures_path.exists() else {}
    materials = {}
    for index, record in enumerate(held_out):
        name = f"material-{index + 1}"
        path = folder / f"{name}.yaml"
        single = {n: q.value for n, q in record.responses.items()}
        path.write_text(yaml.safe_dump(material_config(domain_yaml, record, name, single, sd)))
        runs = truth_runs(path, record, args.repeats)
        targets = {n: statistics.fmean(run[n] for run in runs) for n in single}
        config = material_config(domain_yaml, record, name, targets, sd)
        path.write_text(yaml.safe_dump(config))
        truth = {n: record.parameters[n].value for n in CALIBRATED}
        entry = figures.setdefault(name, {})
        entry |= {"truth": truth, "source": f"{record.study}/{record.evaluation}", "runs": runs}
        materials[name] = (path, config)
        if "scratch" in args.steps:
            scratch_config = {**config, "study": f"{name}-scratch"}
            entry["scratch"] = scratch(
                scratch_config, folder / f"{name}-scratch.yaml", args.scratch_budget, log
            )
        figures_path.write_text(json.dumps(figures, indent=2))
    if "global" in args.steps:
        own = [n for name in materials for n in (name, f"{name}-scratch")] + ["gravel-8-16"]
        demcal("metamodel", "build", args.domain, "--holdout", args.holdout, *own, log=log)
        demcal("metamodel", "validate", args.domain, "--holdout", args.holdout, log=log)
        figures["gradient_boosting_r2"] = gradient_boosting_r2(domain, args.holdout, own)
        log.append(f"gradient boosting, held-out R²: {figures['gradient_boosting_r2']}\n")
        print(log[-1], flush=True)
        for name, (path, _) in materials.items():
            figures[name]["global"] = calibrate_on_both(path, args.domain, args.validate, log)
            figures_path.write_text(json.dumps(figures, indent=2))
        gravel = folder / "gravel-8-16.yaml"
        gravel.write_text(yaml.safe_dump(gravel_config(domain_yaml, log, sd)))
        figures["gravel-8-16"] = {"global": calibrate_on_both(gravel, args.domain, 1, log)}
        figures["campaign"] = dict(
            zip(("simulations", "cpu_s"), campaign_cpu(domain.archive, domain.name))
        )
        figures_path.write_text(json.dumps(figures, indent=2))
        out = ROOT / "benchmarks" / "results" / "global_calibration_output.txt"
        out.write_text("\n".join(log))
        print(f"output: {out.relative_to(ROOT)}")
    print(tables(figures))


def tables(figures: dict) -> str:
    """The README's tables from the figures kept so far."""
    lines = [
        "| material | model | answer μ_pp, density | verdicts | truth within the spans | "
        "shear angle error | bulk density error |",
        "|---|---|---|---|---|---|---|",
    ]
    scratch_lines = [
        "| material | evaluations to the first within both spreads | CPU to it | evaluations, "
        "CPU in all |",
        "|---|---|---|---|",
    ]
    for name, entry in figures.items():
        if "truth" in entry and "global" in entry:
            lines += material_rows(name, entry["truth"], entry)
        if "scratch" in entry:
            s = entry["scratch"]
            first = s["first_within"] or f"none in {s['evaluations']}"
            to_first = (
                "-"
                if s["cpu_to_first_within_s"] is None
                else f"{s['cpu_to_first_within_s'] / 60:.1f} min"
            )
            scratch_lines.append(
                f"| {name} | {first} | {to_first} | {s['evaluations']}, {s['cpu_s'] / 60:.1f} min |"
            )
    return "\n".join([*lines, "", *scratch_lines])


STEPS = ("scratch", "global")


if __name__ == "__main__":
    main()
