"""Registry of the scenes (lab tests) demcal can simulate."""

from __future__ import annotations

from demcal.scenes.base import ResponseSpec, Scene, SettingSpec
from demcal.scenes.calibration_device import SCENE as CALIBRATION_DEVICE
from demcal.scenes.cylinder_lift import SCENE as CYLINDER_LIFT
from demcal.scenes.shear_box import SCENE as SHEAR_BOX

SCENES: dict[str, Scene] = {scene.name: scene for scene in (CYLINDER_LIFT, CALIBRATION_DEVICE, SHEAR_BOX,)}

__all__ = ["SCENES", "ResponseSpec", "Scene", "SettingSpec"]
