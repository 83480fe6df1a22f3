"""Snakemake job: params.json of the 'centre' evaluation (middle of every free
parameter's bounds)."""

from demcal.jobs.steps import write_centre_point

write_centre_point(snakemake)  # noqa: F821  (snakemake is injected by Snakemake)
