"""Snakemake job: figures (PNG) and the best-point table of a calibration."""

from demcal.reporting.figures import write_report_files

write_report_files(snakemake)  # noqa: F821  (snakemake is injected by Snakemake)
