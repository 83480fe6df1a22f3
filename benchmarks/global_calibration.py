"""Richter & Will's (2021) metamodel-based global calibration on the shear box, at this
machine's scale: validation R² of the global models, then three materials calibrated with no
simulation and checked by one.

    python benchmarks/global_calibration.py [--domain config/examples/shear_box_domain.yaml]
        [--holdout shear-box-domain-check] [--materials 3]

Run it in the folder where the campaigns ran (their archive, results/archive.sqlite):

    demcal sample config/examples/shear_box_domain.yaml --n 160
    demcal sample config/examples/shear_box_domain.yaml --n 30 --design latin_hypercube \\
        --name shear-box-domain-check

Steps, each a demcal command:

1. ``demcal metamodel build`` (Kriging and symbolic regression) without the held-out campaign,
   and ``demcal metamodel validate`` on it: R² per response and model.
2. Materials: points of the held-out campaign (parameters known, responses simulated), taken
   in order. Each is given only its two responses as targets (spreads: the seed-to-seed sd of
   the shear box, benchmarks/results/noise_shear-box_shear_box.json) and its PSD (d50,
   sigma_ln), with the other parameters fixed at its values as if measured, except sliding
   friction particle-particle and particle density, which are free (Richter & Will, Tables 4
   and 5). ``demcal calibrate-metamodel --validate 1`` calibrates each on each model kind and
   simulates the answer once.
3. Gravel 8/16 as Richter & Will calibrate it: its PSD from ``demcal psd fit`` of the shipped
   sieve file, their measured wall friction (0.363) and targets (35.53 deg, 1478.8 kg/m^3,
   Table 3), restitution 0.6 (Table 4), rolling friction 0.1 (the shear box example's: LAMMPS'
   rolling model is not theirs); sliding friction and density free.

Prints the tables of benchmarks/README.md, "Global calibration (issue 22)"; writes the
commands' output to benchmarks/results/global_calibration_output.txt.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import yaml

from demcal.archive.store import Archive
from demcal.study.config import load_study_file, read_study_yaml

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


def material_config(domain: dict, record, name: str, sd: dict[str, float]) -> dict:
    """The study file of one material: its truth's responses as targets, its PSD and the
    parameters not in CALIBRATED held at the truth."""
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
        {
            "scene": scene,
            "response": response,
            "value": record.responses[response].value,
            "spread": sd[response],
        }
        for response in ("shear_angle", "bulk_density")
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


def calibrate_on_both(material: Path, domain: str, log: list[str]) -> None:
    """The material calibrated on the Kriging and on the symbolic models, each answer checked
    by one simulation."""
    for kind in ("kriging", "symbolic"):
        demcal(
            "calibrate-metamodel",
            str(material),
            "--domain",
            domain,
            "--model",
            kind,
            "--validate",
            "1",
            log=log,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--domain", default=str(ROOT / "config/examples/shear_box_domain.yaml"))
    parser.add_argument("--holdout", default="shear-box-domain-check")
    parser.add_argument("--materials", type=int, default=3)
    args = parser.parse_args()
    log: list[str] = []
    domain = load_study_file(args.domain)
    demcal("metamodel", "build", args.domain, "--holdout", args.holdout, log=log)
    demcal("metamodel", "validate", args.domain, "--holdout", args.holdout, log=log)
    with Archive(domain.archive) as archive:
        held_out = [
            r for r in archive.records(study=args.holdout, statuses=["ok"]) if len(r.responses) == 2
        ]
    sd = spreads()
    domain_yaml = read_study_yaml(args.domain)
    folder = ROOT / "benchmarks" / "results" / "global_materials"
    folder.mkdir(exist_ok=True)
    for index, record in enumerate(held_out[: args.materials]):
        name = f"material-{index + 1}"
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(material_config(domain_yaml, record, name, sd)))
        truth = {n: record.parameters[n].value for n in CALIBRATED}
        print(f"{name}: {record.study}/{record.evaluation}, truth {truth}", flush=True)
        log.append(f"{name}: {record.study}/{record.evaluation}, truth {truth}\n")
        calibrate_on_both(path, args.domain, log)
    gravel = folder / "gravel-8-16.yaml"
    gravel.write_text(yaml.safe_dump(gravel_config(domain_yaml, log, sd)))
    calibrate_on_both(gravel, args.domain, log)
    out = ROOT / "benchmarks" / "results" / "global_calibration_output.txt"
    out.write_text("\n".join(log))
    print(f"output: {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
