"""The rotating drum's speed and flow regime, shared by its declaration and its drivers."""

from __future__ import annotations

import math
from typing import Any

from demcal.physics.contact import GRAVITY

#: The rolling regime's Froude numbers (Mellmann 2001, Table 1).
ROLLING_FROUDE = (1.0e-4, 1.0e-2)


def angular_speed(settings: dict[str, Any]) -> float:
    """The drum's angular speed [rad/s] from its ``rotation_speed`` [rpm]."""
    return float(settings["rotation_speed"]) * 2.0 * math.pi / 60.0


def froude_number(settings: dict[str, Any]) -> float:
    """Fr = omega^2 R / g: centripetal over gravitational acceleration at the drum's mantle."""
    return angular_speed(settings) ** 2 * float(settings["drum_diameter"]) / 2.0 / GRAVITY


def rotation_speed_range(diameter: float) -> tuple[float, float]:
    """The speeds [rpm] that keep a drum of ``diameter`` [m] in the rolling regime."""
    low, high = (
        60.0 / (2.0 * math.pi) * math.sqrt(froude * GRAVITY / (diameter / 2.0))
        for froude in ROLLING_FROUDE
    )
    return low, high
