"""Snakemake job: the simulate stage of one evaluation (demcal/jobs/evaluation.py)."""

from demcal.jobs.evaluation import run_snakemake_job

run_snakemake_job(snakemake, "simulate")  # noqa: F821  (snakemake is injected by Snakemake)
