"""Registry of the scenes (lab tests) demcal can simulate.

A scene is a package ``demcal/scenes/<scene>/``: its ``__init__.py``
declares it (``SCENE``: parameters, settings, responses, extractors and, per
engine, the driver that runs it), ``analytic.py`` holds its closed-form
stand-in and one module per engine (``lammps.py``, ``liggghts.py``) runs it
on that engine. ``SCENES`` (a :class:`~demcal.plugins.Registry`) names each
scene's declaration, imported when a study first uses the scene; adding a
scene is adding its package and one name here.
"""

from __future__ import annotations

from demcal.plugins import Entry, Registry
from demcal.scenes.base import ResponseSpec, Scene, SettingSpec

SCENES: Registry[Entry] = Registry(
    "scene",
    {
        name: Entry(f"demcal.scenes.{name}:SCENE")
        for name in (
            "cylinder_lift",
            "calibration_device",
            "shear_box",
            "transfer_chute",
            "rotating_drum",
            "uniaxial_compression",
        )
    },
)

__all__ = ["SCENES", "ResponseSpec", "Scene", "SettingSpec"]
