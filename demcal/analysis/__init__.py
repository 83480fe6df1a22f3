"""Analyses of a calibration: the solution space and error against run time."""
