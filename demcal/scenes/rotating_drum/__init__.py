"""Rotating drum (GranuDrum-type instruments): dynamic angle of repose and interface fluctuation.

A horizontal cylinder, its axis along y, is partly filled; the material
settles and the drum turns at constant speed. After a spin-up the free
surface is taken from a number of snapshots over a window of revolutions,
as a camera at the end wall would see it: the dynamic angle of repose is a
line fitted to the time-averaged surface's central part, the interface
fluctuation the rms deviation of single snapshots from that average (drum
instruments turn it into a cohesive index).

The slice along the axis is periodic: no end walls, so the wall friction
acts through the drum's mantle alone, as in a long drum. Lab drums have
glass end walls that raise the angle where the drum is shallow (a few
particle diameters deep); match a deep drum, or read the result as the
long-drum angle.

The regime must be rolling (a steadily flowing, flat surface), which the
Froude number Fr = omega^2 R / g sets: Mellmann (2001) gives 1e-4 < Fr <
1e-2 for rolling; outside it the drum slumps or cascades and a straight
line no longer describes its surface, so the scene refuses the speed.

Defaults: 2 mm beads in a drum of 50 mm (25 diameters) and a periodic
slice 10 mm deep, 40 % filled (about 1100 spheres), turning at 15 rpm
(Fr = 0.0063); a quarter revolution of spin-up, then a quarter revolution
watched in 10 snapshots.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from demcal.errors import ConfigError
from demcal.physics import measure
from demcal.scenes.base import (
    ANGLE_LAB_SPREAD,
    COARSE_PARTICLE_FACTOR,
    MATERIAL_PARAMETERS,
    MAX_ANGLE,
    ResponseSpec,
    Scene,
    SettingSpec,
    check_sizes_in_particles,
    psd_settings,
    settling_settings,
    spheres_to_fill,
)
from demcal.scenes.rotating_drum.analytic import analytic_model
from demcal.scenes.rotating_drum.regime import ROLLING_FROUDE, froude_number, rotation_speed_range

#: Solid fraction of the settled material that ``fill_level`` assumes, to count the spheres.
FILL_SOLID_FRACTION = 0.6
#: Most spheres a drum may need.
MAX_PARTICLES = 100_000
#: The smallest drum diameter and periodic depth, in largest particle diameters.
MIN_DIAMETER_DMAX, MIN_DEPTH_DMAX = 10.0, 3.0
#: demcal's assumed lab-test scatter of the interface fluctuation, a share of its value.
FLUCTUATION_LAB_SHARE = 0.1


def drum_particle_count(settings: dict[str, Any]) -> int:
    """Spheres that fill ``fill_level`` of the drum at ``FILL_SOLID_FRACTION``."""
    radius = float(settings["drum_diameter"]) / 2.0
    volume = float(settings["fill_level"]) * math.pi * radius**2 * float(settings["depth"])
    return spheres_to_fill(volume, settings, FILL_SOLID_FRACTION)


def surface(state: dict[str, np.ndarray], settings: dict[str, Any]) -> tuple[float, float]:
    """Dynamic angle of repose [deg] and interface fluctuation [m] from the saved snapshots."""
    centres, heights = measure.drum_surface_heights(
        state["surface_xz"], state["surface_r"], settings["drum_diameter"] / 2.0, settings["d50"]
    )
    return measure.drum_interface(centres, heights, settings["surface_band"])


def _dynamic_angle(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return surface(state, settings)[0]


def _interface_fluctuation(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return surface(state, settings)[1]


def angle_history(
    state: dict[str, np.ndarray], settings: dict[str, Any]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The angle of each snapshot's surface against simulated time: steady over the window?"""
    centres, heights = measure.drum_surface_heights(
        state["surface_xz"], state["surface_r"], settings["drum_diameter"] / 2.0, settings["d50"]
    )
    angles = [
        measure.drum_interface(centres, heights[k : k + 1], settings["surface_band"])[0]
        for k in range(len(heights))
    ]
    return {"dynamic_angle_of_repose": (state["surface_time"], np.array(angles))}


def check_settings(settings: dict[str, Any], field_prefix: str) -> None:
    """Cross-setting checks a single range cannot express: size, regime, particle count."""
    check_sizes_in_particles(
        settings, field_prefix, {"drum_diameter": MIN_DIAMETER_DMAX, "depth": MIN_DEPTH_DMAX}
    )
    froude = froude_number(settings)
    if not ROLLING_FROUDE[0] <= froude <= ROLLING_FROUDE[1]:
        lowest, highest = rotation_speed_range(settings["drum_diameter"])
        raise ConfigError(
            f"{field_prefix}.rotation_speed: {settings['rotation_speed']:g} rpm gives a Froude "
            f"number of {froude:.2g}, outside the rolling regime ({ROLLING_FROUDE[0]:g} to "
            f"{ROLLING_FROUDE[1]:g}, Mellmann 2001) where the dynamic angle is defined; for this "
            f"drum use {lowest:.3g} to {highest:.3g} rpm"
        )
    count = drum_particle_count(settings)
    if count > MAX_PARTICLES:
        raise ConfigError(
            f"{field_prefix}.depth: the drum needs {count} spheres, more than {MAX_PARTICLES}; "
            f"use a thinner periodic slice (depth), a smaller drum or a lower fill_level"
        )


def coarse_drum(settings: dict[str, Any]) -> dict[str, Any]:
    """The default coarse level: COARSE_PARTICLE_FACTOR times fewer, larger spheres (d50 scaled
    by its cube root) filling the same drum."""
    return {"d50": settings["d50"] * COARSE_PARTICLE_FACTOR ** (1.0 / 3.0)}


SCENE = Scene(
    name="rotating_drum",
    description="rotating drum: dynamic angle of repose and interface fluctuation of the "
    "flowing surface",
    parameters=MATERIAL_PARAMETERS,
    responses={
        "dynamic_angle_of_repose": ResponseSpec(
            "deg",
            "angle of a line fitted to the central part of the time-averaged free surface",
            upper=MAX_ANGLE,
            lab_spread=ANGLE_LAB_SPREAD,
        ),
        "interface_fluctuation": ResponseSpec(
            "m",
            "rms deviation of the snapshots' free surface from its time average",
            lab_spread_share=FLUCTUATION_LAB_SHARE,
        ),
    },
    settings={
        **psd_settings(2.0e-3, 0.0, 2.0),
        "drum_diameter": SettingSpec(0.05, "m", "inner diameter of the drum", 1.0e-3, 10.0),
        "depth": SettingSpec(
            0.01, "m", "thickness of the periodic slice along the drum's axis", 1.0e-4, 10.0
        ),
        "fill_level": SettingSpec(
            0.4,
            "-",
            f"share of the drum's volume the material fills (at a solid fraction of "
            f"{FILL_SOLID_FRACTION:g})",
            0.1,
            0.6,
        ),
        "rotation_speed": SettingSpec(
            15.0, "rpm", "revolutions per minute of the drum", 0.01, 600.0
        ),
        "spinup_revolutions": SettingSpec(
            0.25, "rev", "revolutions before the surface is watched", 0.05, 10.0
        ),
        "window_revolutions": SettingSpec(
            0.25, "rev", "revolutions over which the surface is watched", 0.02, 10.0
        ),
        "snapshots": SettingSpec(
            10, "-", "snapshots of the surface over the window", 2, 1000, integer=True
        ),
        "surface_band": SettingSpec(
            0.6,
            "-",
            "central share of the free surface the line is fitted to (leaves out its ends)",
            0.2,
            0.9,
        ),
        **settling_settings(2.0, "simulated time limit of the settling before the drum turns"),
    },
    analytic_model=analytic_model,
    extractors={
        "dynamic_angle_of_repose": _dynamic_angle,
        "interface_fluctuation": _interface_fluctuation,
    },
    drivers={"lammps": f"{__name__}.lammps:run"},
    check_settings=check_settings,
    size_setting="depth",
    coarse=coarse_drum,
    history=angle_history,
)

#: A tiny drum, seconds per LAMMPS run (3 mm spheres in a drum of 10 diameters, a slice of 3,
#: about 110 spheres, a short spin-up and window): the settings of the scene's tests.
TINY_SETTINGS = {
    "d50": 3.0e-3,
    "drum_diameter": 0.032,
    "depth": 0.01,
    "rotation_speed": 20.0,
    "spinup_revolutions": 0.1,
    "window_revolutions": 0.05,
    "snapshots": 4,
    "max_settle_time": 0.5,
}
