"""Snakemake job: the solution space and sensitivity figures of a calibration."""

from demcal.solution_files import write_report_files

write_report_files(snakemake)  # noqa: F821  (snakemake is injected by Snakemake)
