"""``demcal fidelity check STUDY.yaml [--points N] [--replicates R]``: do the study's cheaper
fidelity levels pay? The same Sobol points at every level (a campaign, into the archive),
then each level against the fine one per response (``demcal.analysis.fidelity``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from demcal.analysis import fidelity
from demcal.cli.options import profile_argument, whole_number
from demcal.cli.sample import simulate
from demcal.cli.study_argument import study_yaml
from demcal.daemon.session import locked_study
from demcal.domain.campaign import (
    check_request,
    forecast,
    plan,
    simulations_per_point,
    write_points,
)
from demcal.errors import ConfigError
from demcal.optimizer import levels
from demcal.resources import DEFAULT_CONFIG
from demcal.results.records import FINE
from demcal.snakemake_command import check_profile
from demcal.study.config import load_study_file

#: The check's design: Sobol points, which the check extends when run again with more.
DESIGN = "sobol"


def arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("action", choices=("check",))
    sub.add_argument(
        "config",
        nargs="?",
        default=DEFAULT_CONFIG,
        metavar="STUDY",
        help="the study's YAML file, with its cheaper levels under fidelities:",
    )
    sub.add_argument(
        "--points",
        type=whole_number(levels.MIN_POINTS, 1000),
        default=8,
        help=f"Sobol points run at every level (default 8, at least {levels.MIN_POINTS})",
    )
    sub.add_argument(
        "--replicates",
        type=whole_number(1, 100),
        default=2,
        help="seeds per point and level (default 2; 2 or more measure each level's noise)",
    )
    sub.add_argument(
        "--levels",
        nargs="+",
        metavar="LEVEL",
        help="the cheaper levels to check (default: all of the study's)",
    )
    sub.add_argument(
        "--name",
        help="the check's study folder (default: <study>-fidelity)",
    )
    profile_argument(sub)


def fidelity_command(args: argparse.Namespace) -> int:
    profile = Path(args.profile)
    settings = check_profile(profile)
    config = study_yaml(args.config, "fidelity check")
    given = load_study_file(config)
    if not given.fidelities:
        raise ConfigError(
            f"{config}: the study has no cheaper fidelity level to check; add one under "
            f"fidelities:, e.g. 'fidelities: {{coarse: default}}' (docs/fidelity.md)"
        )
    levels = args.levels or list(given.fidelities)
    unknown = [name for name in levels if name not in given.fidelities]
    if unknown:
        raise ConfigError(
            f"--levels {unknown[0]}: not a cheaper level of the study "
            f"({', '.join(given.fidelities)})"
        )
    fidelities = [FINE, *dict.fromkeys(levels)]
    given.replicates = args.replicates
    check_request(args.points, DESIGN, per_point=simulations_per_point(given, len(fidelities)))
    name = args.name or f"{given.name}-fidelity"
    with locked_study(config, name=name, replicates=args.replicates) as study:
        campaign = plan(study, args.points, DESIGN, fidelities)
        print(
            f"demcal fidelity: {study.name}, {len(campaign.unit_points)} Sobol points at "
            f"{', '.join(fidelities)}, {study.replicates} seeds each",
            f"demcal fidelity: {forecast(study, campaign, settings)}",
            sep="\n",
            flush=True,
        )
        names = write_points(study, campaign)
        status = simulate(study, names, profile, 1, "fidelity")
        runs = fidelity.runs_table(study, names)
        found = [c for c in fidelity.comparisons(study, runs) if c.level in levels]
        fidelity.table(found).to_csv(study.files.fidelity_table, index=False)
        fidelity.plot(runs, found, study.files.fidelity_figure)
        print(describe(found))
        print(
            f"demcal fidelity: table {study.files.fidelity_table}, "
            f"figure {study.files.fidelity_figure}"
        )
        return status


def describe(found: list[fidelity.LevelComparison]) -> str:
    """The comparisons as a plain table, one line per level and response, then the rule."""
    head = (
        f"{'level':<10} {'response':<32} {'pts':>3} {'r':>6} {'r_lo':>6} {'scale':>7} "
        f"{'bias':>9} {'noise f':>8} {'noise l':>8} {'cost':>6}  verdict"
    )
    lines = [head]
    for c in found:
        lines.append(
            f"{c.level:<10} {c.response:<32} {c.points:>3} {c.correlation:>6.3f} "
            f"{c.correlation_lower:>6.3f} {c.scale:>7.3g} {c.bias:>9.3g} {c.noise_fine:>8.3g} "
            f"{c.noise_level:>8.3g} {c.cost_ratio:>6.2f}  {c.verdict}"
        )
    lines.append(
        f"r: correlation of single runs at the same point, r_lo its {levels.CONFIDENCE:.0%} "
        f"lower bound; fine = scale * level + bias; cost: the level's CPU per simulation / "
        f"fine's. A level pays when (sqrt(1 - r_lo^2) + sqrt(r_lo^2 cost))^2 < 1 (Peherstorfer "
        f"et al. 2016)"
    )
    return "\n".join(lines)
