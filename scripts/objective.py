"""Snakemake job: the objective stage of one evaluation (demcal/evaluation.py)."""

from demcal.evaluation import run_snakemake_job

run_snakemake_job(snakemake, "objective")  # noqa: F821  (snakemake is injected by Snakemake)
