"""Snakemake job: the solution space and sensitivity figures of a calibration."""

from demcal.analysis.solution_report import write_solution_files

write_solution_files(snakemake)  # noqa: F821  (snakemake is injected by Snakemake)
