"""The jobs of one evaluation's DAG (simulate -> extract -> objective), as Snakemake runs them."""
