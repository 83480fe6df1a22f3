"""Snakemake job: the answer's responses over simulated time (scenes that keep a series)."""

from demcal.reporting.figures import write_answer_history

write_answer_history(snakemake)  # noqa: F821  (snakemake is injected by Snakemake)
