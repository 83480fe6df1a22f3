"""Registry of the scenes (lab tests) demcal can simulate."""

from __future__ import annotations

from demcal.scenes.base import ResponseSpec, Scene, SettingSpec
from demcal.scenes.cylinder_lift import SCENE as CYLINDER_LIFT

SCENES: dict[str, Scene] = {scene.name: scene for scene in (CYLINDER_LIFT,)}

__all__ = ["SCENES", "ResponseSpec", "Scene", "SettingSpec"]
