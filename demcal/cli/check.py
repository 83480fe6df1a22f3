"""``demcal check STUDY.yaml``: the study validated as ``demcal run`` validates it, and what
that run would simulate; nothing runs and nothing is written."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from demcal.cli.cost import cost_line, per_scene
from demcal.cli.inspect import study_state
from demcal.cli.study_argument import study_yaml
from demcal.daemon.session import workers_of
from demcal.domain.campaign import runs_at_once
from demcal.optimizer.optimizer import CHEAP_RUNS_PER_FINE
from demcal.snakemake_command import check_profile
from demcal.study.config import load_study_file
from demcal.study.model import Study


def check(args: argparse.Namespace) -> int:
    study = load_study_file(study_yaml(args.config, "check"))
    for warning in study.warnings:
        print(f"demcal: warning: {warning}", file=sys.stderr)
    profile = Path(args.profile)
    settings = check_profile(profile)
    workers, source = workers_of(study, settings, args.workers)
    budget = study.optimizer
    evaluations = budget.max_evaluations + budget.confirm_replicates + budget.map_solutions
    count = evaluations * len(study.scenes) * study.replicates
    print(f"demcal check: {args.config} is a valid study, {study.name!r}; 'demcal run' would run:")
    print("\n".join(f"  {line}" for line in plan_lines(study)))
    print(f"  workers: {workers} evaluations in flight ({source}), profile {profile}")
    at_once = runs_at_once(settings)
    cheap = CHEAP_RUNS_PER_FINE * budget.max_evaluations * len(study.scenes) * study.replicates
    print(
        f"  at most {cost_line(study, per_scene(study, evaluations), count, at_once)}"
        + (f"; and at most {cheap} at {budget.fidelity}" if budget.fidelity else "")
    )
    print(f"  {results_line(study)}")
    return 0


def plan_lines(study: Study) -> list[str]:
    """Engine, scenes, free parameters with their bounds, targets with units, and budget."""
    units = {t.key: study.scenes[t.scene].responses[t.response].unit for t in study.targets}
    free = ", ".join(
        f"{p.name} {p.lower:g} … {p.upper:g}{unit_words(p.spec.unit)}" for p in study.free
    )
    targets = ", ".join(f"{t.key} {t.shown()}{unit_words(units[t.key])}" for t in study.targets)
    settings = study.optimizer
    after = [
        f"{settings.confirm_replicates} confirmation runs of the answer"
        if settings.confirm_replicates
        else "",
        f"{settings.map_solutions} evaluations that map the solution set"
        if settings.map_solutions
        else "",
    ]
    then = "; then " + " and ".join(a for a in after if a) if any(after) else ""
    levels = [
        f"fidelity levels: {', '.join(study.fidelities)} besides fine"
        + (
            f"; the search may spend {settings.fidelity} (at most {CHEAP_RUNS_PER_FINE} runs "
            f"per fine evaluation, docs/fidelity.md)"
            if settings.fidelity
            else "; the search runs fine only (optimizer.fidelity spends a level)"
        )
    ]
    return [
        f"engine: {study.engine.version()}",
        f"scenes: {', '.join(study.scenes)}; {study.replicates} "
        f"replicate{'s' if study.replicates > 1 else ''} of each per evaluation",
        f"free parameters: {free}",
        f"targets: {targets}",
        f"budget: at most {settings.max_evaluations} evaluations (strategy {settings.strategy})"
        f"{then}",
        *(levels if study.fidelities else []),
    ]


def unit_words(unit: str) -> str:
    """The unit after a value, `` Pa``; nothing for a dimensionless one."""
    return "" if unit in ("", "-") else f" {unit}"


def results_line(study: Study) -> str:
    """Whether the run would start the study's folder or continue the calibration in it."""
    folder = study.files.dir
    if not study.files.optimizer.exists():
        return f"results: {folder}/ (new)"
    state, counts = study_state(study)
    return f"results: {folder}/ holds this study already ({state}; {counts}); the run resumes it"
