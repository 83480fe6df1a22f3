"""``demcal solutions`` and ``demcal convergence``: analyses of a study."""

from __future__ import annotations

import argparse

from demcal.cli.inspect import study_of
from demcal.errors import ConfigError


def solutions(args: argparse.Namespace) -> int:
    from demcal.analysis.solution_report import write_solutions

    study = study_of(args.config)
    if not (args.k > 0 and args.samples >= 64):
        raise ConfigError(f"--k {args.k} must be > 0 and --samples {args.samples} at least 64")
    analysis = write_solutions(study, args.k, args.samples)
    s = analysis.solutions
    print(
        f"solution space of {study.name!r}: {len(s.points_unit)} of {s.sampled} sampled "
        f"parameter sets meet every target within {s.k:g} sd (target spread, simulation "
        f"noise and model sd combined)"
    )
    for verdict in analysis.verdicts:
        print(f"  {verdict.sentence}")
    files = study.files
    print(
        f"sets: {files.solutions}; figures: {files.plots / 'solution_space.png'}, "
        f"{files.plots / 'sensitivity.png'}, {files.plots / 'objective_slices.png'}"
    )
    return 0


def convergence(args: argparse.Namespace) -> int:
    from demcal.analysis import convergence as study

    study.run(
        args.config, args.scene, args.fractions, args.sizes, args.seeds, args.jobs, args.point
    )
    return 0
