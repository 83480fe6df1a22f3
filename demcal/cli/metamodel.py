"""``demcal metamodel build|validate|show CONFIG``: global metamodels of a material domain
(:mod:`demcal.metamodel`)."""

from __future__ import annotations

import argparse
import base64
import html
import io
import time

from demcal import metamodel
from demcal.archive.store import Archive
from demcal.errors import ConfigError
from demcal.resources import DEFAULT_CONFIG
from demcal.study.config import load_study_file
from demcal.study.model import Study, load_frozen


def arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("action", choices=("build", "validate", "show"))
    sub.add_argument(
        "config",
        nargs="?",
        default=DEFAULT_CONFIG,
        help="the domain's study file (its free parameters span the domain)",
    )
    sub.add_argument(
        "--model",
        nargs="+",
        default=list(metamodel.MODEL_KINDS),
        choices=metamodel.MODEL_KINDS,
        help="build: the kinds of model (default: both)",
    )
    sub.add_argument(
        "--holdout",
        nargs="*",
        default=[],
        metavar="STUDY",
        help="studies whose simulations are held out of training (build) and validate the "
        "models (validate), e.g. a campaign made with demcal sample --name",
    )
    sub.add_argument("--seed", type=int, default=1, help="build: seed of the model fits")


def domain_study(config: str) -> Study:
    """The domain's study: its frozen copy once a campaign has run, else the YAML."""
    study = load_study_file(config)
    return load_frozen(study.files.study) if study.files.study.is_file() else study


def metamodel_command(args: argparse.Namespace) -> int:
    study = domain_study(args.config)
    if study.archive is None:
        raise ConfigError("archive: false: the metamodels are trained on the archive; give one")
    holdout = tuple(args.holdout)
    if args.action == "build":
        with Archive(study.archive) as archive:
            data = metamodel.domain_data(study, archive, exclude=holdout)
        start = time.monotonic()
        models = metamodel.build(data, tuple(args.model), args.seed, holdout)
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
        with Archive(study.archive) as archive:
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
            f"--holdout {overlap[0]}: the models were trained on its simulations (built with "
            f"--holdout {' '.join(models.exclude) or '(none)'}); build them without it first"
        )
    with Archive(study.archive) as archive:
        held_out = metamodel.domain_data(study, archive, only=holdout)
    results = metamodel.validate(models, held_out)
    if not results:
        raise ConfigError(
            f"--holdout {' '.join(holdout)}: these studies have no simulations of the domain in "
            f"the archive {study.archive}"
        )
    print(validation_table(results))
    page = study.files.dir / "metamodels" / "validation.html"
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
