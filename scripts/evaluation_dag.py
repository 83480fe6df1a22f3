"""Snakemake job: the DAG of one evaluation as SVG (Graphviz)."""

from demcal.reporting.figures import write_evaluation_dag

write_evaluation_dag(snakemake)  # noqa: F821  (snakemake is injected by Snakemake)
