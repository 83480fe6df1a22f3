"""Snakemake job: the archive stage of one evaluation (demcal/jobs/steps.py)."""

from demcal.jobs.steps import run_snakemake_job

run_snakemake_job(snakemake, "archive")  # noqa: F821  (snakemake is injected by Snakemake)
