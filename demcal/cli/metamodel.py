"""``demcal metamodel build|validate|show STUDY``: global metamodels of a material domain
(:mod:`demcal.domain.metamodel`)."""

from __future__ import annotations

import argparse
import base64
import html
import io
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from demcal.archive.store import Archive
from demcal.cli.options import MOST_SIMULATIONS, profile_argument, whole_number
from demcal.cli.study_argument import has_run, study_of, study_yaml
from demcal.domain import calibration, metamodel
from demcal.errors import ConfigError
from demcal.optimizer.membership import BAND_WORDS
from demcal.optimizer.objective import relative_miss
from demcal.resources import DEFAULT_CONFIG
from demcal.results.archive_url import missing_file
from demcal.results.storage import write_json
from demcal.snakemake_command import check_profile
from demcal.study.config import load_study_file
from demcal.study.model import Study

#: The largest seed of the model fits (NumPy's legacy seeding takes 32 bits).
LARGEST_SEED = 2**32 - 1
#: The most L-BFGS-B starts of calibrate-metamodel (about 0.06 s each on a 2-parameter domain).
MOST_STARTS = 1024


def arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("action", choices=("build", "validate", "show"))
    sub.add_argument(
        "config",
        nargs="?",
        default=DEFAULT_CONFIG,
        metavar="STUDY",
        help="the domain's study: its YAML file, or its name once a campaign has run (its free "
        "parameters span the domain)",
    )
    sub.add_argument(
        "--model",
        nargs="+",
        default=list(metamodel.SINGLE_LEVEL_KINDS),
        choices=metamodel.MODEL_KINDS,
        help="build: the kinds of model (default: kriging and symbolic; multi_fidelity needs "
        "--fidelity)",
    )
    sub.add_argument(
        "--fidelity",
        metavar="LEVEL",
        help="build: the cheaper level of the study whose runs the multi_fidelity model learns "
        "from as well (demcal sample --fidelity LEVEL runs them)",
    )
    sub.add_argument(
        "--holdout",
        nargs="*",
        default=[],
        metavar="STUDY",
        help="studies whose simulations are held out of training (build) and validate the "
        "models (validate), e.g. a campaign made with demcal sample --name",
    )
    sub.add_argument(
        "--seed",
        type=whole_number(0, LARGEST_SEED),
        default=1,
        help=f"build: seed of the model fits, 0 to {LARGEST_SEED}",
    )


def domain_study(config: str) -> tuple[Study, str]:
    """The domain's study (its frozen copy once a campaign has run, else the YAML) and its
    archive; refused without an archive, or when its SQLite file does not exist yet."""
    study = study_of(config)
    if study.archive is None:
        raise ConfigError("archive: false: the metamodels are trained on the archive; give one")
    absent = missing_file(study.archive)
    if absent is not None:
        raise ConfigError(
            f"no archive at {absent} yet: run demcal sample {config} --points N first"
        )
    return study, study.archive


def metamodel_command(args: argparse.Namespace) -> int:
    study, url = domain_study(args.config)
    holdout = tuple(args.holdout)
    if args.action == "build":
        if args.fidelity is not None and args.fidelity not in study.fidelities:
            raise ConfigError(
                f"--fidelity {args.fidelity}: not a cheaper level of the study "
                f"({', '.join(study.fidelities) or 'it declares none under fidelities:'})"
            )
        with Archive(url) as archive:
            data = metamodel.domain_data(study, archive, exclude=holdout)
            cheap = (
                None
                if args.fidelity is None
                else (
                    args.fidelity,
                    metamodel.domain_data(study, archive, exclude=holdout, fidelity=args.fidelity),
                )
            )
        start = time.monotonic()
        models = metamodel.build(data, tuple(args.model), args.seed, holdout, cheap)
        path = metamodel.save(study, models)
        print(
            f"demcal metamodel: {', '.join(args.model)} models of {len(models.models)} responses "
            f"over {len(models.names)} inputs, trained in {time.monotonic() - start:.0f} s; "
            f"saved to {path}"
        )
        print(describe(models))
        return 0
    models = metamodel.load(study)
    if args.action == "show":
        with Archive(url) as archive:
            now = metamodel.domain_data(study, archive, exclude=models.exclude).fingerprint
        print(describe(models))
        if now != models.fingerprint:
            print(
                "stale: the archive's simulations of the domain have changed since the build; "
                "run demcal metamodel build again"
            )
        return 0
    if not holdout:
        raise ConfigError("validate: give --holdout STUDY, the held-out simulations")
    overlap = [name for name in holdout if name not in models.exclude]
    if overlap:
        raise ConfigError(
            f"--holdout {overlap[0]}: the models were not built with it held out (built with "
            f"--holdout {' '.join(models.exclude) or '(none)'}); build them with "
            f"--holdout {overlap[0]} first"
        )
    with Archive(url) as archive:
        held_out = metamodel.domain_data(study, archive, only=holdout)
    results = metamodel.validate(models, held_out)
    if not results:
        raise ConfigError(
            f"--holdout {' '.join(holdout)}: these studies have no simulations of the domain in "
            f"the archive {study.archive}"
        )
    print(validation_table(results))
    page = study.files.metamodel_validation
    page.write_text(validation_page(study, models, results))
    print(f"\nresidual histograms and the worst points: {page}")
    return 0


def describe(models: metamodel.Metamodels) -> str:
    lines = ["inputs (x_name = (name - lower) / (upper - lower)):"]
    lines += [
        f"  {name}: [{lo:g}, {hi:g}]"
        for name, lo, hi in zip(models.names, models.lower, models.upper)
    ]
    if models.exclude:
        lines.append(f"held out of training: {', '.join(models.exclude)}")
    for key, by_kind in models.models.items():
        lines.append(f"{key}: trained on {models.training_size[key]} simulations")
        lines += [f"  {kind}: {model.describe()}" for kind, model in by_kind.items()]
    return "\n".join(lines)


def validation_table(results: list[metamodel.Validation]) -> str:
    lines = ["| response | model | held-out simulations | R² | RMSE |", "|---|---|---|---|---|"]
    lines += [f"| {r.key} | {r.kind} | {r.count} | {r.r2:.4f} | {r.rmse:.4g} |" for r in results]
    return "\n".join(lines)


def validation_page(
    study: Study, models: metamodel.Metamodels, results: list[metamodel.Validation]
) -> str:
    """A small HTML page: the table, each model's residual histogram, its worst points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parts = [
        f"<h1>Metamodels of {html.escape(study.name)}: validation</h1>",
        f"<pre>{html.escape(validation_table(results))}</pre>",
    ]
    for r in results:
        figure, axes = plt.subplots(figsize=(5, 3))
        axes.hist(r.residuals, bins=min(20, max(5, r.count // 3)))
        axes.set_xlabel(f"simulated - predicted ({r.key})")
        axes.set_ylabel("simulations")
        axes.set_title(f"{r.kind}: R² {r.r2:.3f}, RMSE {r.rmse:.3g}")
        buffer = io.BytesIO()
        figure.tight_layout()
        figure.savefig(buffer, format="png", dpi=90)
        plt.close(figure)
        image = base64.b64encode(buffer.getvalue()).decode()
        worst = "".join(
            f"<tr><td>{html.escape(s)}</td><td>{y:.4g}</td><td>{p:.4g}</td></tr>"
            for s, y, p in r.worst
        )
        parts.append(
            f"<h2>{html.escape(r.key)}, {r.kind}</h2><img src='data:image/png;base64,{image}'>"
            f"<table><tr><th>simulation</th><th>simulated</th><th>predicted</th></tr>{worst}"
            f"</table>"
        )
    body = "\n".join(parts)
    return f"<!doctype html><html><head><meta charset='utf-8'></head><body>{body}</body></html>"


def calibrate_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--domain",
        required=True,
        metavar="STUDY",
        help="the domain's study, its YAML file or its name (whose metamodels demcal metamodel "
        "build made)",
    )
    sub.add_argument(
        "--model",
        default="kriging",
        choices=metamodel.MODEL_KINDS,
        help="the metamodels to calibrate on (default kriging)",
    )
    sub.add_argument(
        "--starts",
        type=whole_number(1, MOST_STARTS),
        default=32,
        help=f"L-BFGS-B starts, 1 to {MOST_STARTS} (default 32)",
    )
    sub.add_argument(
        "--validate",
        type=whole_number(0, MOST_SIMULATIONS),
        default=0,
        metavar="N",
        help="then simulate the answer N times (seeds of their own) and compare "
        f"(0 to {MOST_SIMULATIONS})",
    )
    profile_argument(sub, "validation simulations")


def calibrate_command(args: argparse.Namespace) -> int:
    """``demcal calibrate-metamodel MATERIAL --domain DOMAIN``: a material calibrated on the
    domain's metamodels with no simulation, then optionally validated by simulation."""
    if args.validate:  # simulations of the material: its YAML file, as for demcal run
        study_yaml(args.config, "calibrate-metamodel --validate")
    material = study_of(args.config) if has_run(args.config) else load_study_file(args.config)
    domain, _ = domain_study(args.domain)
    free, held = calibration.material_inputs(domain, material)
    models = metamodel.load(domain)
    if args.model not in next(iter(models.models.values())):
        raise ConfigError(f"--model {args.model}: not built; run demcal metamodel build --model")
    unmodelled = [t.key for t in material.targets if t.key not in models.models]
    if unmodelled:
        raise ConfigError(
            f"targets: the domain's models predict {', '.join(models.models)}, not "
            f"{unmodelled[0]}; target those responses, or add it to the domain's targets and "
            f"build the models again"
        )
    from demcal.analysis.solution_report import plot_corner, solutions_table

    start = time.monotonic()
    explore = extend_command(domain, args.domain)
    result = calibration.calibrate(models, args.model, material, free, held, args.starts, explore)
    best = result.optima[0]
    print(
        f"demcal calibrate-metamodel: {material.name} on the {args.model} models of "
        f"{domain.name}, {args.starts} L-BFGS-B starts and the solution set, "
        f"{time.monotonic() - start:.1f} s, no simulation"
    )
    print("held: " + ", ".join(f"{n} = {v:g}" for n, v in held.items()))
    for rank, optimum in enumerate(result.optima[:5], 1):
        values = ", ".join(f"{n} = {v:.4g}" for n, v in optimum.values.items())
        print(
            f"optimum {rank} ({optimum.starts} starts, objective {optimum.objective:.3g}): {values}"
        )
    for target in material.targets:
        print(
            f"  {target.key}: predicted {best.predicted[target.key]:.4g}, target {target.shown()}"
        )
    solutions = result.analysis.solutions
    likely = int(np.sum(solutions.likely))
    print(
        f"solution set: {likely} of {solutions.sampled} sampled parameter sets likely meet every "
        f"target within {solutions.k:g} sd ({BAND_WORDS}, under the models' uncertainty)"
    )
    if not likely:
        print(f"  {calibration.no_solution_reason(result)}")
    for verdict in result.analysis.verdicts:
        print(f"  {verdict.sentence}")
    files = material.files.metamodel_calibration(args.model)
    files.dir.mkdir(parents=True, exist_ok=True)
    table, figure, path = files.solutions, files.solution_space, files.summary
    solutions_table(result.analysis).to_csv(table, index=False, float_format="%.6g")
    plot_corner(result.analysis, {"parameters": best.values}, figure)
    summary = {
        "domain": domain.name,
        "model": args.model,
        "models_fingerprint": models.fingerprint,
        "held": held,
        "optima": [asdict(optimum) for optimum in result.optima],
        "solution_set": {
            "k": solutions.k,
            "sampled": solutions.sampled,
            "likely": likely,
            "noise_sd": solutions.noise_sd,
            "verdicts": [asdict(verdict) for verdict in result.analysis.verdicts],
        },
        "validation": None,
    }
    write_json(path, summary)  # kept even if the validation is interrupted
    print(f"solution set: {table}, {figure}; summary: {path}")
    if args.validate:
        summary["validation"] = validate_answer(args, material, best)
        write_json(path, summary)
    return 0


def extend_command(domain: Study, config: str) -> str:
    """The command that adds simulations to the domain: its campaign, doubled (``--points`` is
    the campaign's new size, not the number of points to add)."""
    from demcal.results.records import CampaignRecord

    campaign = CampaignRecord.read_if_any(domain.files.campaign)
    size = 0 if campaign is None else len(campaign.unit_points)
    yaml = config if Path(config).is_file() else "DOMAIN.yaml"  # sample needs the YAML file
    return f"demcal sample {yaml} --points {max(2 * size, 2 * len(domain.free) + 2)}"


def validate_answer(
    args: argparse.Namespace, material: Study, best: calibration.Optimum
) -> dict[str, dict[str, Any]]:
    """Simulate the answer ``args.validate`` times; each response's relative error against the
    target and against the metamodels' prediction (printed, and returned per target)."""
    from demcal.cli.cost import cost_line, per_scene
    from demcal.daemon.session import locked_study
    from demcal.domain.campaign import run, runs_at_once, simulations_per_point
    from demcal.jobs.steps import response_paths
    from demcal.results.records import PointRecord, ResponsesRecord, Status

    profile = Path(args.profile)
    settings = check_profile(profile)
    with locked_study(args.config) as study:
        count = args.validate * simulations_per_point(study)
        at_once = runs_at_once(settings)
        print(
            f"validation: {cost_line(study, per_scene(study, args.validate), count, at_once)}",
            flush=True,
        )
        names = [f"validate-{args.model}-{i}" for i in range(args.validate)]
        for name in names:
            params = study.files.evaluation(name).params
            point = PointRecord(best.values, proposed_by="calibrate-metamodel")
            if not params.exists() or PointRecord.read(params).parameters != best.values:
                point.write(params)
        try:
            state = run(study, names, profile, lambda tally: None)
        except KeyboardInterrupt:
            print("demcal: validation interrupted; run the same command again", file=sys.stderr)
            raise SystemExit(130) from None
        values: dict[str, list[float]] = {t.key: [] for t in study.targets}
        for name in names:
            for path in response_paths(study, name):
                record = ResponsesRecord.read(path)
                if record.status == Status.OK:
                    scene = path.parent.parent.name
                    for response, value in record.responses.items():
                        values.setdefault(f"{scene}.{response}", []).append(value)
    print(f"validation: {state.line()}")
    errors: dict[str, dict[str, Any]] = {}
    for target in study.targets:
        simulated = values[target.key]
        if not simulated:
            print(f"  {target.key}: no simulation succeeded")
            continue
        mean = float(np.mean(simulated))
        predicted = best.predicted[target.key]
        errors[target.key] = {
            "simulated": simulated,
            "mean": mean,
            "error_against_target": relative_miss(target, mean),
            "error_against_metamodel": (mean - predicted) / predicted,
        }
        print(
            f"  {target.key}: simulated {mean:.4g} ({len(simulated)} runs), "
            f"{100 * errors[target.key]['error_against_target']:+.2f} % against the target, "
            f"{100 * errors[target.key]['error_against_metamodel']:+.2f} % against the metamodel"
        )
    return errors
