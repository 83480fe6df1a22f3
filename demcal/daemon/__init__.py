"""The calibration daemon: owns the optimizer, runs one child Snakemake per evaluation.

- ``loop``: the calibration loop (``Calibration``: propose, launch, collect,
  retry, early-termination watch, stopping rules);
- ``session``: a study read, frozen and locked, and its calibration run to the end;
- ``launcher``: child Snakemakes (start, alive, re-attach);
- ``termination``: what running simulations report, fed to the optimizer's rule;
- ``progress``: the progress line;
- ``tables``: what the loop exports (``evaluations.csv``, ``best.json``);
- ``control``: the lock, ``demcal stop``, ``add-point``, ``rerun-failed``.
"""
