"""Snakemake job: the archive stage of one evaluation (demcal/jobs/evaluation.py)."""

from demcal.jobs.evaluation import run_snakemake_job

run_snakemake_job(snakemake, "archive")  # noqa: F821  (snakemake is injected by Snakemake)
