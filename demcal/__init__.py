"""demcal: calibration of discrete element method (DEM) simulations.

From Python (a notebook):

```python
import demcal

results = demcal.open("results/quickstart")  # a calibration's results
study = demcal.load("study.yaml")  # a study file, validated
results = study.run()  # calibrated as `demcal run` does
```

See [demcal.api][demcal.api]. The packages by concern, from the ground up (the order
``.importlinter`` checks): ``physics`` (granular helpers, the parameter catalogue),
``results`` (files and records under ``results/<study>/``), ``engines`` and ``scenes``
(simulators and lab tests), ``optimizer`` (surrogate-based ask/tell and the objective),
``study`` (the study file and model), ``archive`` (every simulation, kept once), ``jobs``
(the jobs of one evaluation), ``daemon`` (the calibration loop), ``reporting``,
``analysis``, ``domain`` (sampled domains and their global metamodels), and ``cli`` (the
``demcal`` command) beside ``api``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from demcal.api import load, open

__version__ = "0.1.0"

__all__ = ["load", "open"]


def __getattr__(name: str) -> object:
    # on first use (PEP 562): `import demcal` stays light for the jobs, which import
    # demcal's modules and need neither pandas nor the study's SciPy-based imports
    if name in __all__:
        return getattr(importlib.import_module("demcal.api"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
