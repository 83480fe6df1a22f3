"""demcal: calibration of discrete element method (DEM) simulations.

From Python (a notebook):

```python
import demcal

results = demcal.open("results/quickstart")  # a calibration's results
study = demcal.load("study.yaml")  # a study file, validated
results = study.run()  # calibrated as `demcal run` does
```

See [demcal.api][demcal.api]. The packages by concern: ``study`` (the study, its
parameters, targets and objective), ``results`` (files and records under
``results/<study>/``), ``jobs`` (the jobs of one evaluation), ``physics``,
``engines`` and ``scenes`` (simulators and lab tests), ``optimizer``
(surrogate-based ask/tell), ``daemon`` (the calibration loop),
``reporting``, ``analysis`` and ``cli`` (the ``demcal`` command).
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
