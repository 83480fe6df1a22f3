"""demcal: calibration of discrete element method (DEM) simulations.

Layout: ``parameters`` (catalogue of material parameters), ``scenes`` (lab
tests: what they read and what they measure), ``engines`` (simulators),
``config`` (study validation), ``evaluation`` (simulate -> extract ->
objective, the jobs of one evaluation's Snakemake DAG), ``optimizer``
(surrogate-based ask/tell library).
"""

__version__ = "0.1.0"
