"""The calibration daemon: owns the optimizer, runs one child Snakemake per evaluation.

- ``loop``: the calibration loop (``Calibration``: propose, launch, collect,
  retry, early-termination watch, stopping rules);
- ``children``: child-process supervision (start, alive, re-attach, profiles);
- ``watch``: the early-termination decision, a pure function fed by the loop;
- ``tables``: what the loop exports (``evaluations.csv``, ``best.json``);
- ``control``: ``demcal stop`` and ``demcal rerun-failed``.
"""
