# demcal: calibration of DEM simulations as a Snakemake workflow.
#
# One evaluation = one parameter point = one DAG:
#   simulate[scene, replicate] -> extract[scene, replicate] -> objective
# under results/<study>/evals/<id>/ (file contract: DESIGN.md, demcal/evaluation.py).
#
#   snakemake --cores 2                         # one evaluation at the centre of the bounds
#   snakemake --cores 2 results/<study>/evals/<id>/objective.json   # a given params.json
#   snakemake --configfile config/examples/<x>.yaml ...             # another study

import time

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version

from demcal.config import load_study
from demcal.errors import ConfigError
from demcal.summary import recent_summaries

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


include: "workflow/rules/evaluation.smk"


rule all:
    default_target: True
    input:
        CENTRE + "/objective.json",


onsuccess:
    for summary in recent_summaries(STUDY, RUN_START):
        print(summary)
