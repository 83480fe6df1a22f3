"""Snakemake job: the simulate stage of one evaluation (demcal/jobs/steps.py)."""

from demcal.jobs.steps import run_snakemake_job

run_snakemake_job(snakemake, "simulate")  # noqa: F821  (snakemake is injected by Snakemake)
