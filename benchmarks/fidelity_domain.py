"""The shear-box material domain learnt from a coarse campaign plus a small fine one (issue 38,
Richter & Will's 2021 route with a cheaper level), against Kriging of fine runs alone.

    python benchmarks/fidelity_domain.py [--fine 40] [--extra 24] [--coarse 160]
        [--holdout 30] [--materials 3] [--repeats 3] [--validate 3]

Run it in an empty folder (it writes the domain's study file there and keeps the archive,
results/archive.sqlite; a second run resumes: campaigns extend, figures already measured are
kept). The domain is config/examples/shear_box_domain.yaml with its default coarse level (a
box of 6 instead of 10 d_max). Campaigns:

    demcal sample shear-box-domain.yaml --points FINE
    demcal sample shear-box-domain.yaml --points COARSE --fidelity coarse \\
        --name shear-box-domain-coarse
    demcal sample shear-box-domain.yaml --points EXTRA --name shear-box-domain-extra
    demcal sample shear-box-domain.yaml --points HOLDOUT --design latin_hypercube \\
        --name shear-box-domain-check

Models, each validated on the held-out campaign (R², RMSE) and used to calibrate the first
``--materials`` held-out points as materials (benchmarks/global_calibration.py: μ_pp and
density free, the rest held at the truth, targets the mean of the truth's run and
``--repeats`` more), each answer checked by ``--validate`` simulations:

- ``kriging``: the FINE fine runs alone;
- ``multi_fidelity``: the same fine runs and the COARSE coarse ones;
- ``kriging, equal CPU``: the FINE + EXTRA fine runs, about the CPU of the two campaigns
  of ``multi_fidelity`` (``--extra 0``: no such campaign and model).

Prints the README's table and writes benchmarks/results/fidelity_domain.json (every figure)
and fidelity_domain_output.txt (every command's output).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from global_calibration import (  # noqa: E402
    CALIBRATED,
    campaign_cpu,
    demcal,
    material_config,
    spreads,
    truth_runs,
)

from demcal.archive.store import Archive  # noqa: E402
from demcal.study.config import load_study_file  # noqa: E402
from demcal.study.study_file import read_study_yaml  # noqa: E402

DOMAIN = "shear-box-domain"
EXTRA = f"{DOMAIN}-extra"
COARSE = f"{DOMAIN}-coarse"
HOLDOUT = f"{DOMAIN}-check"
RESULTS = ROOT / "benchmarks" / "results"
FIGURES = RESULTS / "fidelity_domain.json"
#: the model builds: (label, the kinds built, the campaigns left out besides the held-out one)
BUILDS = (
    ("fine and coarse", ("kriging", "multi_fidelity"), (EXTRA,)),
    ("equal CPU", ("kriging",), ()),
)


def validation_table(output: str) -> dict[str, dict[str, float]]:
    """R² and RMSE per response and model kind from ``demcal metamodel validate``'s table."""
    scores: dict[str, dict[str, float]] = {}
    for line in output.splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if len(cells) == 5 and cells[0].startswith("shear_box."):
            scores[f"{cells[0]} {cells[1]}"] = {"r2": float(cells[3]), "rmse": float(cells[4])}
    return scores


def calibrate(material: Path, kind: str, validate: int, log: list[str]) -> dict:
    """``demcal calibrate-metamodel`` of one material on one kind of model, with validation:
    its summary (results/<material>/metamodel/<kind>/calibration.json)."""
    demcal(
        "calibrate-metamodel",
        str(material),
        "--domain",
        f"{DOMAIN}.yaml",
        "--model",
        kind,
        "--validate",
        str(validate),
        log=log,
    )
    name = yaml.safe_load(material.read_text())["study"]
    path = Path("results") / name / "metamodel" / kind / "calibration.json"
    summary: dict = json.loads(path.read_text())
    return summary


def campaigns(args: argparse.Namespace, log: list[str]) -> None:
    """The four campaigns (each resumes or extends where it stopped)."""
    study = f"{DOMAIN}.yaml"
    demcal("sample", study, "--points", str(args.fine), log=log)
    demcal(
        "sample",
        study,
        "--points",
        str(args.coarse),
        "--fidelity",
        "coarse",
        "--name",
        COARSE,
        log=log,
    )
    if args.extra:
        demcal("sample", study, "--points", str(args.extra), "--name", EXTRA, log=log)
    demcal(
        "sample",
        study,
        "--points",
        str(args.holdout),
        "--design",
        "latin_hypercube",
        "--name",
        HOLDOUT,
        log=log,
    )


def campaign_costs(url: str) -> dict[str, dict[str, float]]:
    """Simulations and CPU seconds of each campaign."""
    names = {"fine": DOMAIN, "coarse": COARSE, EXTRA: EXTRA, HOLDOUT: HOLDOUT}
    return {
        label: dict(zip(("simulations", "cpu_s"), campaign_cpu(url, name)))
        for label, name in names.items()
    }


def materials(
    args: argparse.Namespace, url: str, domain_yaml: dict, builds: tuple
) -> dict[str, dict]:
    """The first held-out points as materials: study files (one per build) and truths."""
    with Archive(url) as archive:
        held_out = [
            r for r in archive.records(study=HOLDOUT, statuses=["ok"]) if len(r.responses) == 2
        ][: args.materials]
    sd = spreads()
    out = {}
    for index, record in enumerate(held_out):
        name = f"mf-material-{index + 1}"
        path = Path(f"{name}.yaml")
        single = {n: q.value for n, q in record.responses.items()}
        path.write_text(yaml.safe_dump(material_config(domain_yaml, record, name, single, sd)))
        runs = truth_runs(path, record, args.repeats)
        targets = {n: statistics.fmean(run[n] for run in runs) for n in single}
        studies = {}
        for label, _, _ in builds:
            study = name if label == BUILDS[0][0] else f"{name}-{label.replace(' ', '-')}"
            studies[label] = Path(f"{study}.yaml")
            config = material_config(domain_yaml, record, study, targets, sd)
            studies[label].write_text(yaml.safe_dump(config))
        out[name] = {
            "truth": {n: record.parameters[n].value for n in CALIBRATED},
            "targets": targets,
            "runs": runs,
            "files": studies,
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fine", type=int, default=40)
    parser.add_argument("--extra", type=int, default=24)
    parser.add_argument("--coarse", type=int, default=160)
    parser.add_argument("--holdout", type=int, default=30)
    parser.add_argument("--materials", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--validate", type=int, default=3)
    args = parser.parse_args()
    domain_yaml = read_study_yaml(ROOT / "config/examples/shear_box_domain.yaml")
    domain_yaml["fidelities"] = {"coarse": "default"}
    Path(f"{DOMAIN}.yaml").write_text(yaml.safe_dump(domain_yaml, sort_keys=False))
    url = load_study_file(f"{DOMAIN}.yaml").archive
    log: list[str] = []
    figures = json.loads(FIGURES.read_text()) if FIGURES.exists() else {}
    campaigns(args, log)
    figures["campaigns"] = campaign_costs(url)
    builds = BUILDS if args.extra else BUILDS[:1]
    chosen = materials(args, url, domain_yaml, builds)
    own = [path.stem for entry in chosen.values() for path in entry["files"].values()]
    for label, kinds, left_out in builds:
        extra = ["--fidelity", "coarse"] if "multi_fidelity" in kinds else []
        demcal(
            "metamodel",
            "build",
            f"{DOMAIN}.yaml",
            "--holdout",
            HOLDOUT,
            *(left_out if args.extra else ()),
            *own,
            "--model",
            *kinds,
            *extra,
            log=log,
        )
        output = demcal("metamodel", "validate", f"{DOMAIN}.yaml", "--holdout", HOLDOUT, log=log)
        build = figures.setdefault("builds", {}).setdefault(label, {})
        build["validation"] = validation_table(output)
        for name, entry in chosen.items():
            result = {
                "truth": entry["truth"],
                "targets": entry["targets"],
                "runs": entry["runs"],
            }
            for kind in kinds:
                result[kind] = calibrate(entry["files"][label], kind, args.validate, log)
            build.setdefault("materials", {})[name] = result
            FIGURES.write_text(json.dumps(figures, indent=2))
    (RESULTS / "fidelity_domain_output.txt").write_text("\n".join(log))
    print(tables(figures))


def tables(figures: dict) -> str:
    """The README's table: per build and kind, held-out R² and the materials' errors."""
    lines = [
        "| model | training | angle R² (RMSE) | density R² (RMSE) | shear angle error "
        "per material | bulk density error per material |",
        "|---|---|---|---|---|---|",
    ]
    costs = figures["campaigns"]
    for label, build in figures.get("builds", {}).items():
        for kind in ("kriging", "multi_fidelity"):
            if f"shear_box.shear_angle {kind}" not in build["validation"]:
                continue
            campaigns = (
                ["fine"]
                + ([EXTRA] if label == "equal CPU" else [])
                + (["coarse"] if kind == "multi_fidelity" else [])
            )
            fine = sum(costs[c]["simulations"] for c in campaigns if c != "coarse")
            training = f"{fine} fine" + (
                f" + {costs['coarse']['simulations']} coarse" if kind == "multi_fidelity" else ""
            )
            cpu = sum(costs[c]["cpu_s"] for c in campaigns)
            scores = [
                build["validation"][f"shear_box.{response} {kind}"]
                for response in ("shear_angle", "bulk_density")
            ]
            errors = [
                ", ".join(
                    f"{100 * m[kind]['validation'][key]['error_against_target']:+.1f} %"
                    for m in build.get("materials", {}).values()
                    if kind in m and m[kind].get("validation")
                )
                for key in ("shear_box.shear_angle", "shear_box.bulk_density")
            ]
            lines.append(
                f"| {kind} | {training}, {cpu / 3600:.2f} CPU h | "
                f"{scores[0]['r2']:.3f} ({scores[0]['rmse']:.2f}°) | "
                f"{scores[1]['r2']:.4f} ({scores[1]['rmse']:.1f}) | {errors[0]} | {errors[1]} |"
            )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
