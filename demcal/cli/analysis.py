"""``demcal solutions`` and ``demcal convergence``: analyses of a study."""

from __future__ import annotations

import argparse
import math
import os
from typing import TYPE_CHECKING

from demcal.analysis.solutions import SOLUTION_SAMPLES, membership_word
from demcal.cli.cost import cost_line, per_scene
from demcal.cli.options import ASSIGNMENT, MOST_SIMULATIONS, former_name, whole_number
from demcal.cli.study_argument import study_of, study_source
from demcal.daemon.control import explore_solutions, lock_study
from demcal.domain.campaign import runs_at_once
from demcal.errors import ConfigError
from demcal.optimizer.membership import BAND_WORDS
from demcal.reporting.terminal import advised_test, posterior_line
from demcal.snakemake_command import LOCAL_PROFILE, check_profile
from demcal.study.model import Study

if TYPE_CHECKING:
    from demcal.analysis.solution_report import SolutionAnalysis


def solutions(args: argparse.Namespace) -> int:
    from demcal.analysis.solution_report import analyse, write_solutions

    if not 0 < args.tolerance < math.inf:  # NaN fails too
        raise ConfigError(
            f"--tolerance {args.tolerance}: give a number of standard deviations above 0"
        )
    study = study_of(args.config)
    if args.explore is not None:
        return explore(study, args.explore)
    if args.point:
        values = study.free_values(args.point, "--point")
        return print_point_check(study, analyse(study, args.tolerance, args.samples), values)
    analysis = write_solutions(study, args.tolerance, args.samples)
    s = analysis.solutions
    print(
        f"solution space of {study.name!r}: of {s.sampled} sampled parameter sets, "
        f"{int(s.likely.sum())} are likely to meet every target within {s.k:g} sd "
        f"({BAND_WORDS}) and {len(s.points_unit)} cannot be ruled out; "
        f"{100 * s.unsure_share:.0f} % of those are undecided"
    )
    for verdict in analysis.verdicts:
        print(f"  {verdict.sentence}")
    intervals = {v.name: (v.posterior_low, v.posterior_high) for v in analysis.verdicts}
    print(f"  {posterior_line(intervals, s.posterior.effective_samples)}")
    advised = advised_test(study.files.advice)
    if advised:
        print(f"  {advised}")
    files = study.files
    print(
        f"sets: {files.solutions}; figures: {files.plots / 'solution_space.png'}, "
        f"{files.plots / 'sensitivity.png'}, {files.plots / 'objective_slices.png'}"
    )
    return 0


def print_point_check(study: Study, analysis: SolutionAnalysis, values: dict[str, float]) -> int:
    """``--point NAME=VALUE ...``: whether one parameter set (a literature value, a colleague's,
    a known truth) meets the targets, on the study's response models."""
    from demcal.analysis.solution_report import check_point

    check = check_point(analysis, values)
    point = ", ".join(f"{name}={values[name]:g}" for name in analysis.names)
    print(
        f"{point}: probability {check.probability:.2f} that every response meets its target "
        f"within {analysis.solutions.k:g} sd: {membership_word(check.probability)}"
    )
    for t in study.targets:
        mean, sd = check.predicted[t.key]
        unit = study.scenes[t.scene].responses[t.response].unit
        print(
            f"  {t.key}: predicted {mean:.4g} ±{sd:.2g} {unit}, target {t.shown()}, band "
            f"±{check.half_width[t.key]:.2g} ({analysis.solutions.k:g} sd)"
        )
    return 0


def explore(study: Study, evaluations: int) -> int:
    """``--explore N``: queue N simulations that map the solution set."""
    lock = lock_study(study)  # noqa: F841  (no daemon may run meanwhile)
    explore_solutions(study, evaluations)
    count = evaluations * study.replicates * len(study.scenes)
    at_once = runs_at_once(check_profile(LOCAL_PROFILE))
    print(
        f"demcal: {evaluations} evaluations that map the solution set of {study.name!r} are "
        "queued; the next 'demcal run' or 'snakemake --profile ...' simulates them, then "
        f"'demcal solutions {study.name}' gives the verdicts anew",
        f"demcal: the next run with {LOCAL_PROFILE.parent.name}/{LOCAL_PROFILE.name}: "
        f"{cost_line(study, per_scene(study, evaluations), count, at_once)}",
        sep="\n",
    )
    return 0


def convergence(args: argparse.Namespace) -> int:
    from demcal.analysis import convergence as study

    config = study_source(args.config)
    sweep = study.sweep(config, args.scene, args.fractions, args.sizes, args.point)
    runs = {sweep.scene: args.seeds * sum(sweep.relative_cost(v) for v in sweep.variants)}
    count = args.seeds * len(sweep.variants)
    notes = [
        "finer time steps counted as longer runs" if sweep.study.engine.steps_in_time else "",
        "larger sizes take longer still" if sweep.base.size < max(sweep.sizes()) else "",
    ]
    print(
        f"demcal convergence: {sweep.describe()}",
        "; ".join(
            [f"demcal convergence: {cost_line(sweep.study, runs, count, args.workers)}"]
            + [note for note in notes if note]
        ),
        sep="\n",
        flush=True,
    )
    study.run(sweep, args.seeds, args.workers)
    return 0


#: The most simulations in flight of ``demcal convergence``.
MOST_WORKERS = 1024


def solutions_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--tolerance",
        type=float,
        default=2.0,
        metavar="K",
        help="tolerance in combined standard deviations (each target's standard error and "
        "model discrepancy; default 2)",
    )
    former_name(sub, "--k", "--tolerance", type=float)
    sub.add_argument(
        "--samples",
        type=whole_number(*SOLUTION_SAMPLES),
        default=2**16,
        help=f"Sobol points sampled over the box, {SOLUTION_SAMPLES[0]} to "
        f"{SOLUTION_SAMPLES[1]} (default 65536)",
    )
    sub.add_argument(
        "--point",
        nargs="+",
        metavar=ASSIGNMENT,
        help="judge one parameter set (every free parameter, once) against the targets",
    )
    sub.add_argument(
        "--explore",
        type=whole_number(1, MOST_SIMULATIONS),
        metavar="N",
        help="queue N simulations where membership in the solution set is least certain, "
        f"for the next run (1 to {MOST_SIMULATIONS})",
    )


#: The most seeds per variant of ``demcal convergence``.
MOST_SEEDS = 100


def convergence_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("--scene", help="default: the study's first scene")
    sub.add_argument(
        "--fractions",
        type=float,
        nargs="+",
        help="time steps as fractions of the Rayleigh time (default 0.5 0.35 0.25 0.125)",
    )
    sub.add_argument(
        "--sizes",
        type=float,
        nargs="+",
        help="values of the scene's size setting (particle count or box "
        "scale; default 0.5, 1 and 2 times the configured one)",
    )
    sub.add_argument(
        "--seeds",
        type=whole_number(1, MOST_SEEDS),
        default=2,
        help=f"seeds per variant, 1 to {MOST_SEEDS}",
    )
    workers = whole_number(1, MOST_WORKERS)
    sub.add_argument(
        "--workers",
        type=workers,
        default=os.cpu_count() or 1,
        help=f"simulations in flight, 1 to {MOST_WORKERS} (default: this machine's cores)",
    )
    former_name(sub, "--jobs", "--workers", type=workers)
    sub.add_argument(
        "--point",
        nargs="*",
        default=[],
        metavar=ASSIGNMENT,
        help="free parameter values (default: centre of the bounds)",
    )
