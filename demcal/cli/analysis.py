"""``demcal solutions`` and ``demcal convergence``: analyses of a study."""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING

from demcal.analysis.solutions import membership_word, posterior_line
from demcal.cli.inspect import study_of
from demcal.daemon.control import explore_solutions, lock_study
from demcal.errors import ConfigError
from demcal.study.model import Study

if TYPE_CHECKING:
    from demcal.analysis.solution_report import SolutionAnalysis


def solutions(args: argparse.Namespace) -> int:
    from demcal.analysis.solution_report import analyse, write_solutions

    if not 0 < args.k < math.inf:  # NaN fails too
        raise ConfigError(f"--k {args.k}: give a number of standard deviations above 0")
    study = study_of(args.config)
    if args.explore is not None:
        return explore(study, args.explore)
    if args.point:
        values = study.free_values(args.point, "--point")
        return print_point_check(study, analyse(study, args.k, args.samples), values)
    analysis = write_solutions(study, args.k, args.samples)
    s = analysis.solutions
    print(
        f"solution space of {study.name!r}: of {s.sampled} sampled parameter sets, "
        f"{int(s.likely.sum())} are likely to meet every target within {s.k:g} sd (target "
        f"spread and simulation noise combined) and {len(s.points_unit)} cannot be ruled out; "
        f"{100 * s.unsure_share:.0f} % of those are undecided"
    )
    for verdict in analysis.verdicts:
        print(f"  {verdict.sentence}")
    intervals = {v.name: (v.posterior_low, v.posterior_high) for v in analysis.verdicts}
    print(f"  {posterior_line(intervals, s.posterior.effective_samples)}")
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
            f"  {t.key}: predicted {mean:.4g} ±{sd:.2g} {unit}, target {t.shown()} "
            f"±{check.half_width[t.key]:.2g} ({analysis.solutions.k:g} sd of spread and noise)"
        )
    return 0


def explore(study: Study, evaluations: int) -> int:
    """``--explore N``: queue N simulations that map the solution set."""
    lock = lock_study(study)  # noqa: F841  (no daemon may run meanwhile)
    explore_solutions(study, evaluations)
    print(
        f"demcal: {evaluations} evaluations that map the solution set of {study.name!r} are "
        "queued; the next 'demcal run' or 'snakemake --profile ...' simulates them, then "
        f"'demcal solutions {study.name}' gives the verdicts anew"
    )
    return 0


def convergence(args: argparse.Namespace) -> int:
    from demcal.analysis import convergence as study

    study.run(
        args.config, args.scene, args.fractions, args.sizes, args.seeds, args.jobs, args.point
    )
    return 0
