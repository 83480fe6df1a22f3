# Functions of the rules, apart from the rules (snakemake --lint: no rules and
# functions in one file).

import contextlib
import shutil
from pathlib import Path

from demcal.study.model import freeze
from demcal.snakemake_command import invocation_profile  # the --profile of this Snakemake

# Snakemake's options that draw the jobs instead of running them.
GRAPH_OPTIONS = ("--dag", "--rulegraph", "--filegraph", "--d3dag")

# The evaluation that graphs draw in place of all of them (calibrate.smk).
SHOWN_ID = "each"


def graph_requested(argv):
    """Whether a Snakemake command line asks for a graph of the jobs."""
    return any(arg.split("=", 1)[0] in GRAPH_OPTIONS for arg in argv)


def freeze_study(study, preview):
    """The study frozen (freeze()), and the study.json the DAG is to see.

    A preview (dry run, graph) writes nothing outside .snakemake/: the study is
    checked against its study.json as a run checks it, in a copy under
    .snakemake/demcal/preview/, and the DAG sees the copy where a run would
    write (a new or changed study: then newer than the calibration, as the
    real file would be).
    """
    if not preview:
        frozen = freeze(study)
        return frozen, str(frozen.files.study)
    scratch = Path(".snakemake", "demcal", "preview")
    real = study.files.study
    copy = scratch / real
    copy.parent.mkdir(parents=True, exist_ok=True)
    copy.unlink(missing_ok=True)
    if real.exists():
        shutil.copyfile(real, copy)
    with contextlib.chdir(scratch):
        frozen = freeze(study)
    unchanged = real.exists() and real.read_bytes() == copy.read_bytes()
    return frozen, str(real if unchanged else copy)


def evaluation_params(wildcards):
    """An evaluation's point (params.json, written by the daemon); none for the evaluation a
    graph draws for all, which has no point."""
    if GRAPH and wildcards.evaluation == SHOWN_ID:
        return []
    return [str(FILES.evaluation(wildcards.evaluation).params)]


def calibration_plan(study):
    """What the calibrate job does, in one line (its message, which a dry run shows)."""
    scenes = len(study.scenes)
    return (
        f"demcal: calibrate study {study.name!r}: up to {study.optimizer.max_evaluations} "
        f"evaluations x {scenes} scene{'s' if scenes > 1 else ''} ({', '.join(study.scenes)}) "
        f"x {study.replicates} replicate{'s' if study.replicates > 1 else ''} of "
        "simulate -> extract -> objective, each evaluation a child Snakemake; "
        "then plots, solutions and the report"
    )
