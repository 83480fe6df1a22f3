"""Registry of the scenes (lab tests) demcal can simulate.

A scene is a package ``demcal/scenes/<scene>/``: its ``__init__.py``
declares it (``SCENE``: parameters, settings, responses, extractors and, per
engine, the driver that runs it), ``analytic.py`` holds its closed-form
stand-in and one module per engine (``lammps.py``, ``liggghts.py``) runs it
on that engine.
"""

from __future__ import annotations

from demcal.scenes.base import ResponseSpec, Scene, SettingSpec
from demcal.scenes.calibration_device import SCENE as CALIBRATION_DEVICE
from demcal.scenes.cylinder_lift import SCENE as CYLINDER_LIFT
from demcal.scenes.shear_box import SCENE as SHEAR_BOX

SCENES: dict[str, Scene] = {
    scene.name: scene
    for scene in (
        CYLINDER_LIFT,
        CALIBRATION_DEVICE,
        SHEAR_BOX,
    )
}

__all__ = ["SCENES", "ResponseSpec", "Scene", "SettingSpec"]
