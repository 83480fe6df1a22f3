"""Cylinder lift test (Rackl & Hanley 2017, section 2.2): bulk density and angle of repose.

Particles are generated into a cylinder standing on a plate with a low rim
ring of the cylinder's radius and settle; optionally the fill is trimmed to a
height and settles again, as in Rackl & Hanley's rig. The poured bulk density
is taken from the settled fill. The cylinder is then lifted at constant speed; the
material flows out and forms a heap on the plate, the ring holding its
bottom layer as in Rackl & Hanley's rig (material may flow over the ring onto
the plate; beyond the plate's edge it leaves). When the heap has come to rest
its angle of repose is measured from the final positions.

Defaults: 2000 spheres of 2 mm in a 25 mm cylinder give a fill of about one
cylinder diameter, so the heap angle stays sensitive to friction; the lift
speed is Rackl & Hanley's 10 mm/s (the angle depends on it: take it from the
lab test being matched). The angle-of-repose method is a setting because the
figure depends on how it is measured as much as on the material.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from demcal.errors import ConfigError
from demcal.physics import measure
from demcal.physics.psd import diameter_range
from demcal.scenes.base import (
    ANGLE_LAB_SPREAD,
    BULK_DENSITY_LAB_SHARE,
    MATERIAL_PARAMETERS,
    MAX_ANGLE,
    MAX_BULK_DENSITY,
    ResponseSpec,
    Scene,
    SettingSpec,
    coarse_by_particle_count,
    psd_settings,
    settling_settings,
)
from demcal.scenes.cylinder_lift.analytic import analytic_model


def _bulk_density(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    density, _height = measure.fill_bulk_density(
        state["fill_x"],
        state["fill_r"],
        state["fill_mass"],
        settings["cylinder_diameter"] / 2.0,
        settings["d50"],
    )
    return density


def _angle_of_repose(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    if settings["aor_method"] == "flank_fit":
        return measure.heap_angle_flank_fit(
            state["heap_x"],
            state["heap_r"],
            settings["d50"],
            (settings["aor_band_lower"], settings["aor_band_upper"]),
        )
    return measure.heap_angle_height_radius(
        state["heap_x"], state["heap_r"], settings["d50"], bottom_layer=settings["d50"]
    )


def check_geometry(settings: dict[str, Any], field_prefix: str) -> None:
    """Cross-setting checks a single range cannot express."""
    d_min, d_max = diameter_range(settings["d50"], settings["sigma_ln"], settings["psd_truncation"])
    if settings["cylinder_diameter"] < 6.0 * d_max:
        raise ConfigError(
            f"{field_prefix}.cylinder_diameter: {settings['cylinder_diameter']:g} m is less than "
            f"6 of the largest particles ({d_max:g} m); use at least {6 * d_max:g} m"
        )
    if settings["plate_width"] < settings["cylinder_diameter"]:
        raise ConfigError(
            f"{field_prefix}.plate_width: {settings['plate_width']:g} m is smaller than the "
            f"cylinder ({settings['cylinder_diameter']:g} m)"
        )
    if settings["aor_band_lower"] >= settings["aor_band_upper"]:
        raise ConfigError(
            f"{field_prefix}.aor_band_lower: {settings['aor_band_lower']:g} must be below "
            f"aor_band_upper ({settings['aor_band_upper']:g})"
        )


SCENE = Scene(
    name="cylinder_lift",
    description="cylinder lift test: poured bulk density and angle of repose of the heap",
    parameters=MATERIAL_PARAMETERS,
    responses={
        "bulk_density": ResponseSpec(
            "kg/m^3",
            "mass of the settled fill / (pi R^2 fill height)",
            upper=MAX_BULK_DENSITY,
            lab_spread_share=BULK_DENSITY_LAB_SHARE,
        ),
        "angle_of_repose": ResponseSpec(
            "deg",
            "angle of the heap flank after the lift",
            upper=MAX_ANGLE,
            lab_spread=ANGLE_LAB_SPREAD,
        ),
    },
    settings={
        "particle_count": SettingSpec(2000, "-", "number of spheres", 10, 1_000_000, integer=True),
        **psd_settings(2.0e-3, 0.0, 2.0),
        "cylinder_diameter": SettingSpec(
            25.0e-3, "m", "inner diameter of the cylinder", 1.0e-4, 10.0
        ),
        "trim_height": SettingSpec(
            0.0,
            "m",
            "trim height: spheres whose centre lies above it are removed once the fill has "
            "settled, which then settles again (Rackl & Hanley: 50 mm); 0 = no trim",
            0.0,
            10.0,
        ),
        "ring_height": SettingSpec(
            1.2e-3, "m", "height of the rim ring at the cylinder radius (0 = bare plate)", 0.0, 1.0
        ),
        "plate_width": SettingSpec(
            100.0e-3, "m", "width of the square plate: material beyond it leaves", 1.0e-4, 20.0
        ),
        "lift_speed": SettingSpec(0.01, "m/s", "cylinder lift speed", 1.0e-4, 1.0),
        **settling_settings(2.0, "simulated time limit of each settling stage"),
        "aor_method": SettingSpec(
            "flank_fit", "", "angle of repose measure", choices=("flank_fit", "height_radius")
        ),
        "aor_band_lower": SettingSpec(
            0.2, "-", "flank fit: lowest surface height, fraction of heap height", 0.0, 0.9
        ),
        "aor_band_upper": SettingSpec(
            0.8, "-", "flank fit: highest surface height, fraction of heap height", 0.1, 1.0
        ),
    },
    analytic_model=analytic_model,
    extractors={"bulk_density": _bulk_density, "angle_of_repose": _angle_of_repose},
    drivers={"lammps": f"{__name__}.lammps:run", "liggghts": f"{__name__}.liggghts:case"},
    check_settings=check_geometry,
    coarse=coarse_by_particle_count,
)

#: A tiny cylinder lift, seconds per LAMMPS or LIGGGHTS run (200 spheres of 3 mm lifted at
#: 0.05 m/s): the settings of the engine tests and of the benchmarks' quick real runs.
TINY_SETTINGS = {
    "particle_count": 200,
    "d50": 3.0e-3,
    "cylinder_diameter": 24.0e-3,
    "plate_width": 0.08,
    "lift_speed": 0.05,
    "max_settle_time": 0.6,
}
