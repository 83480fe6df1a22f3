# demcal: calibration of DEM simulations as a Snakemake workflow.
#
# The default target is the calibration (rule calibrate: the demcal daemon).
# One evaluation = one parameter point = one DAG:
#   simulate[scene, replicate] -> extract[scene, replicate] -> objective
# under results/<study>/evals/<id>/ (file contract: DESIGN.md, demcal/evaluation.py).
#
#   snakemake --profile profiles/local           # calibrate config/config.yaml
#   snakemake --profile profiles/slurm           # the same, simulations as SLURM jobs
#   snakemake --profile profiles/local evaluate_centre          # one point, centre of the bounds
#   snakemake --profile profiles/local results/<study>/evals/<id>/objective.json  # a given params.json
#   snakemake --configfile config/examples/<x>.yaml ...         # another study

import os
import sys
import time

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version

from demcal.config import load_study
from demcal.errors import ConfigError
from demcal.summary import recent_summaries, write_report

min_version("9.0")


# A study given with --configfile replaces the default instead of being merged into it.
if not config:

    configfile: "config/config.yaml"


RUN_START = time.time()
try:
    STUDY = load_study(config)
except ConfigError as exc:
    raise WorkflowError(f"invalid configuration: {exc}") from None
for warning in STUDY.warnings:
    logger.warning(f"demcal: {warning}")


localrules:
    all,
    evaluate_centre,


include: "workflow/rules/evaluation.smk"
include: "workflow/rules/calibrate.smk"
include: "workflow/rules/report.smk"


report: "workflow/report/workflow.rst"


rule all:
    default_target: True
    input:
        rules.plots.output,
        rules.evaluation_dag.output,


rule evaluate_centre:
    input:
        CENTRE + "/objective.json",


onsuccess:
    # A calibration ends with its report (the daemon printed the best point);
    # single evaluations get their summaries here.
    if os.path.exists(rules.plots.output[0]) and os.path.getmtime(rules.plots.output[0]) >= RUN_START:
        print(write_report(workflow.main_snakefile, workflow.configfiles[0], STUDY))
    else:
        for summary in recent_summaries(STUDY, RUN_START):
            print(summary)
