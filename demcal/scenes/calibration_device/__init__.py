"""Calibration device (Samuelsson 2023, sec. 4.1, after Quist and Evertsson): hopper, slide, pile.

Material fills a hopper whose outlet is closed by a trapdoor. The trapdoor
opens; the material flows out onto an inclined slide (particle-wall
friction), leaves the slide over its lower edge and forms a pile on the
floor below, against the slide's support.
Three responses:

- ``mass_flow`` [kg/s]: slope of the mass held in the hopper against time
  (sampled every ``sample_interval``), over the middle of the discharge;
  mostly sensitive to particle-particle friction. The rate over the first
  half of the discharge is the early estimate for early termination (the
  thesis' choice: it is known about halfway through the run).
- ``slide_time`` [s]: time from opening until less than
  ``slide_empty_fraction`` of the material is in the hopper or on the slide;
  if that never happens within ``max_time``, ``max_time + 10 * remaining /
  total`` (the thesis' penalty); sensitive to particle-wall friction.
- ``angle_of_repose`` [deg]: sigmoid fitted to the pile's longer flank (the
  surface profile from its crest outwards; with the defaults, towards the
  end wall), angle at its inflexion point.

The rig here is a slice of the device: periodic in depth (y), so the pile
is a 2-D ridge and the outlet a slot across the whole depth; geometry
entirely from LAMMPS regions. Only what the targeted responses need is
simulated: with mass flow alone the run ends when the hopper is empty.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal.errors import ConfigError, SimulationFailed
from demcal.physics import measure
from demcal.physics.psd import diameter_range
from demcal.scenes.base import (
    ANGLE_LAB_SPREAD,
    MASS_FLOW_LAB_SHARE,
    MATERIAL_PARAMETERS,
    MAX_ANGLE,
    SLIDE_TIME_LAB_SHARE,
    ResponseSpec,
    Scene,
    SettingSpec,
    coarse_by_particle_count,
    psd_settings,
    settling_settings,
)
from demcal.scenes.calibration_device.analytic import analytic_model

#: Discharged fractions between which the hopper's mass is fitted for the mass flow.
MASS_FLOW_BAND = (0.2, 0.8)
#: Discharged fraction at which the early estimate of the mass flow is written.
EARLY_ESTIMATE_AT = 0.5


@dataclass(frozen=True)
class DeviceGeometry:
    """Where the device's parts are [m]; x along the device, z up, y periodic (depth).

    Floor z = 0 from the end wall x = 0 to the slide's support at
    ``slide_edge``; the slide's lower edge is there at height
    ``slide_edge_height`` and it rises at ``slide_angle`` (solid below it).
    The hopper's outlet spans
    [``outlet_left``, ``outlet_left + orifice_width``] at height
    ``hopper_bottom``; its left wall is vertical, its right wall leans out at
    ``hopper_wall_angle`` up to ``hopper_top``. ``box_right`` closes the device.
    """

    slide_edge: float
    slide_edge_height: float
    outlet_left: float
    hopper_bottom: float
    hopper_top: float
    fill_top: float
    box_right: float
    wall_thickness: float


def device_geometry(
    settings: dict[str, Any], particle_volume: float, d_max: float, insertion_solid_fraction: float
) -> DeviceGeometry:
    """Place the parts for ``particle_volume`` [m^3] of spheres no larger than ``d_max``.

    The hopper is made tall enough that the spheres, inserted at
    ``insertion_solid_fraction``, fit between its walls: the insertion zone
    over height h has the area w h + h^2 / (2 tan beta), w the outlet width
    less the wall clearance, beta the right wall's angle.
    """
    slide = math.radians(settings["slide_angle"])
    beta = math.radians(settings["hopper_wall_angle"])
    width, thickness = settings["orifice_width"], d_max
    edge, edge_height = settings["floor_length"], settings["slide_edge_height"]
    outlet_left = edge + settings["slide_length"] * math.cos(slide) - width / 2.0
    slide_height_at_outlet = edge_height + math.tan(slide) * (outlet_left + width - edge)
    bottom = slide_height_at_outlet + settings["drop_height"] + thickness
    area = particle_volume / (insertion_solid_fraction * (settings["depth"] - d_max))
    clear_width = width - 1.2 * d_max
    if beta >= math.radians(89.9):
        fill = area / clear_width
    else:
        t = math.tan(beta)
        fill = t * (-clear_width + math.sqrt(clear_width**2 + 2.0 * area / t))
    fill_top = bottom + 0.6 * d_max + fill
    top = fill_top + 2.0 * d_max
    right = outlet_left + width + thickness + (top - bottom) / math.tan(beta) + 2.0 * d_max
    return DeviceGeometry(edge, edge_height, outlet_left, bottom, top, fill_top, right, thickness)


def _angle_of_repose(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    """Sigmoid fit of the pile's longer flank, measured from its crest outwards."""
    position, height = measure.surface_profile_along_x(
        state["heap_x"], state["heap_r"], settings["d50"], (0.0, settings["floor_length"])
    )
    if len(height) == 0:
        raise SimulationFailed("no pile on the floor: no angle of repose to measure")
    crest = position[np.argmax(height)]
    towards_wall, towards_slide = position <= crest, position >= crest
    if towards_wall.sum() >= towards_slide.sum():
        return measure.heap_angle_sigmoid_fit(crest - position[towards_wall], height[towards_wall])
    return measure.heap_angle_sigmoid_fit(position[towards_slide] - crest, height[towards_slide])


def check_geometry(settings: dict[str, Any], field_prefix: str) -> None:
    """Cross-setting checks a single range cannot express."""
    _, d_max = diameter_range(settings["d50"], settings["sigma_ln"], settings["psd_truncation"])
    for name, multiple in (("orifice_width", 3.0), ("depth", 3.0), ("floor_length", 10.0)):
        if settings[name] < multiple * d_max:
            raise ConfigError(
                f"{field_prefix}.{name}: {settings[name]:g} m is less than {multiple:g} of the "
                f"largest particles ({d_max:g} m); use at least {multiple * d_max:g} m"
            )
    if settings["slide_angle"] >= settings["hopper_wall_angle"]:
        raise ConfigError(
            f"{field_prefix}.slide_angle: {settings['slide_angle']:g} deg is not below "
            f"hopper_wall_angle ({settings['hopper_wall_angle']:g} deg): the slide, rising "
            f"under the hopper's sloping wall, would cut into the hopper; use a smaller "
            f"slide_angle or a steeper hopper_wall_angle"
        )
    if settings["slide_length"] * 2.0 < settings["orifice_width"]:
        raise ConfigError(
            f"{field_prefix}.slide_length: {settings['slide_length']:g} m puts the outlet past "
            f"the slide's edge; use at least half the orifice_width "
            f"({settings['orifice_width'] / 2.0:g} m)"
        )


SCENE = Scene(
    name="calibration_device",
    description="hopper discharging onto a slide: mass flow, slide time, angle of repose "
    "of the pile (Samuelsson 2023)",
    parameters=MATERIAL_PARAMETERS,
    responses={
        "mass_flow": ResponseSpec(
            "kg/s",
            "slope of the hopper's mass against time over 20-80 % discharged",
            lab_spread_share=MASS_FLOW_LAB_SHARE,
        ),
        "slide_time": ResponseSpec(
            "s",
            "time from opening until the hopper and slide are empty, penalised if never",
            lab_spread_share=SLIDE_TIME_LAB_SHARE,
        ),
        "angle_of_repose": ResponseSpec(
            "deg",
            "angle at the inflexion point of a sigmoid fitted to the pile profile",
            upper=MAX_ANGLE,
            lab_spread=ANGLE_LAB_SPREAD,
        ),
    },
    settings={
        "particle_count": SettingSpec(1500, "-", "number of spheres", 10, 1_000_000, integer=True),
        **psd_settings(2.0e-3, 0.0, 2.0),
        "depth": SettingSpec(
            10.0e-3, "m", "depth of the periodic slice of the device", 1.0e-4, 1.0
        ),
        "orifice_width": SettingSpec(
            12.0e-3, "m", "width of the hopper outlet (slot across the depth)", 1.0e-4, 1.0
        ),
        "hopper_wall_angle": SettingSpec(
            60.0, "deg", "angle of the hopper's sloping wall to the horizontal", 30.0, 90.0
        ),
        "slide_angle": SettingSpec(35.0, "deg", "inclination of the slide", 5.0, 80.0),
        "slide_length": SettingSpec(
            60.0e-3,
            "m",
            "distance along the slide from its lower edge to below the outlet's centre",
            1.0e-4,
            10.0,
        ),
        "slide_edge_height": SettingSpec(
            40.0e-3,
            "m",
            "height of the slide's lower edge above the floor (above the pile)",
            0.0,
            10.0,
        ),
        "drop_height": SettingSpec(
            10.0e-3, "m", "gap between the hopper's outlet and the slide", 0.0, 10.0
        ),
        "floor_length": SettingSpec(
            150.0e-3,
            "m",
            "floor from the end wall to the slide's support (where the pile forms)",
            1.0e-4,
            10.0,
        ),
        "sample_interval": SettingSpec(
            0.01, "s", "simulated time between samples of the hopper and slide masses", 1.0e-4, 1.0
        ),
        "max_time": SettingSpec(
            3.0, "s", "simulated time limit after the trapdoor opens", 0.05, 100.0
        ),
        "slide_empty_fraction": SettingSpec(
            0.003,
            "-",
            "slide counts as empty below this share of the material (thesis: 0.01 of 3.5 kg)",
            0.0,
            0.5,
        ),
        **settling_settings(2.0, "simulated time limit of each settling stage"),
    },
    analytic_model=analytic_model,
    extractors={"angle_of_repose": _angle_of_repose},
    drivers={"lammps": f"{__name__}.lammps:run"},
    check_settings=check_geometry,
    coarse=coarse_by_particle_count,
)

#: A tiny calibration device, seconds per LAMMPS run (300 spheres of 2 mm on a short floor
#: and slide): the settings of the scene's tests and of the benchmarks' quick real runs.
TINY_SETTINGS = {
    "particle_count": 300,
    "d50": 2.0e-3,
    "floor_length": 0.08,
    "slide_length": 0.03,
    "slide_edge_height": 0.02,
    "max_time": 1.0,
    "max_settle_time": 0.5,
}
