"""Confined uniaxial compression: bulk density under a seating and a maximum stress, loading
and unloading moduli.

A cylinder on a floor is filled with material that settles; a piston then
comes down onto it at ``piston_speed`` until the stress on the piston
reaches ``max_stress``, and goes back up until the stress has fallen to the
``seating_stress``. The stress is the force on the piston over the
cylinder's cross-section; the strain is the piston's travel below its height
at the seating stress (an oedometer's seating load, which flattens the
poured surface) over that height. Responses:

- ``seated_bulk_density`` and ``compressed_bulk_density``: the material's
  mass over the volume under the piston at the seating and at the maximum
  stress;
- ``loading_modulus`` and ``unloading_modulus``: the slope of stress against
  strain between ``modulus_band_lower`` of the maximum stress and the maximum,
  on the way down and on the way back (the constrained moduli of an
  oedometer). Unloading is nearly elastic, so it is the response that pins
  Young's modulus; loading adds rearrangement, which friction governs.

Rackl & Hanley (2017, sec. 4) name such a test for materials whose stiffness
matters. Defaults: 2 mm beads filling a cylinder of 25 mm to 25 mm (about
1760 spheres), seated at 1 kPa and loaded to 10 kPa at 5 mm/s.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from demcal.errors import ConfigError
from demcal.physics import measure
from demcal.scenes.base import (
    BULK_DENSITY_LAB_SHARE,
    COARSE_PARTICLE_FACTOR,
    MATERIAL_PARAMETERS,
    MAX_BULK_DENSITY,
    ResponseSpec,
    Scene,
    SettingSpec,
    check_sizes_in_particles,
    psd_settings,
    settling_settings,
    spheres_to_fill,
)
from demcal.scenes.uniaxial_compression.analytic import analytic_model

#: Solid fraction of the poured fill that ``fill_height`` assumes, to count the spheres.
FILL_SOLID_FRACTION = 0.6
#: Most spheres a fill may need.
MAX_PARTICLES = 100_000
#: The smallest cylinder diameter and fill height, in largest particle diameters.
MIN_DIAMETER_DMAX, MIN_HEIGHT_DMAX = 6.0, 5.0
#: demcal's assumed lab-test scatter of a modulus, a share of its value.
MODULUS_LAB_SHARE = 0.1


def fill_particle_count(settings: dict[str, Any]) -> int:
    """Spheres that fill the cylinder to ``fill_height`` at ``FILL_SOLID_FRACTION``."""
    volume = cross_section(settings) * float(settings["fill_height"])
    return spheres_to_fill(volume, settings, FILL_SOLID_FRACTION)


def cross_section(settings: dict[str, Any]) -> float:
    """The cylinder's inner cross-section [m^2], which the piston covers."""
    return math.pi * float(settings["cylinder_diameter"]) ** 2 / 4.0


def seated_height(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    """The piston's height [m] where loading first reached the seating stress."""
    loading = state["loading"].astype(bool)
    return measure.height_at_stress(
        state["gap"][loading], state["stress"][loading], settings["seating_stress"]
    )


def density_at(state: dict[str, np.ndarray], settings: dict[str, Any], stress: float) -> float:
    """Bulk density [kg/m^3] under the piston where loading first reached ``stress`` [Pa]."""
    loading = state["loading"].astype(bool)
    height = measure.height_at_stress(state["gap"][loading], state["stress"][loading], stress)
    return float(np.sum(state["mass"]) / (cross_section(settings) * height))


def _seated_bulk_density(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return density_at(state, settings, settings["seating_stress"])


def _compressed_bulk_density(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return density_at(state, settings, settings["max_stress"])


def modulus(state: dict[str, np.ndarray], settings: dict[str, Any], loading: bool) -> float:
    """The loading or unloading modulus [Pa] from the saved stress-height curve."""
    branch = state["loading"].astype(bool) == loading
    seated = seated_height(state, settings)
    top = settings["max_stress"]
    return measure.tangent_modulus(
        (seated - state["gap"][branch]) / seated,
        state["stress"][branch],
        (settings["modulus_band_lower"] * top, top),
    )


def _loading_modulus(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return modulus(state, settings, loading=True)


def _unloading_modulus(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return modulus(state, settings, loading=False)


def check_settings(settings: dict[str, Any], field_prefix: str) -> None:
    """Cross-setting checks a single range cannot express: size and particle count."""
    check_sizes_in_particles(
        settings,
        field_prefix,
        {"cylinder_diameter": MIN_DIAMETER_DMAX, "fill_height": MIN_HEIGHT_DMAX},
    )
    if settings["seating_stress"] >= settings["max_stress"]:
        raise ConfigError(
            f"{field_prefix}.seating_stress: {settings['seating_stress']:g} Pa must be below "
            f"max_stress ({settings['max_stress']:g} Pa)"
        )
    if settings["modulus_band_lower"] * settings["max_stress"] < settings["seating_stress"]:
        raise ConfigError(
            f"{field_prefix}.modulus_band_lower: the moduli's band would start at "
            f"{settings['modulus_band_lower'] * settings['max_stress']:g} Pa, below the seating "
            f"stress ({settings['seating_stress']:g} Pa), where unloading ends; raise it to at "
            f"least {settings['seating_stress'] / settings['max_stress']:g}"
        )
    count = fill_particle_count(settings)
    if count > MAX_PARTICLES:
        raise ConfigError(
            f"{field_prefix}.fill_height: the fill needs {count} spheres, more than "
            f"{MAX_PARTICLES}; use a smaller cylinder or a lower fill_height"
        )


def coarse_fill(settings: dict[str, Any]) -> dict[str, Any]:
    """The default coarse level: COARSE_PARTICLE_FACTOR times fewer, larger spheres (d50 scaled
    by its cube root) filling the same cylinder."""
    return {"d50": settings["d50"] * COARSE_PARTICLE_FACTOR ** (1.0 / 3.0)}


SCENE = Scene(
    name="uniaxial_compression",
    description="confined uniaxial compression: bulk density poured and under load, loading "
    "and unloading moduli",
    parameters=MATERIAL_PARAMETERS,
    responses={
        "seated_bulk_density": ResponseSpec(
            "kg/m^3",
            "mass / volume under the piston at the seating stress",
            upper=MAX_BULK_DENSITY,
            lab_spread_share=BULK_DENSITY_LAB_SHARE,
        ),
        "compressed_bulk_density": ResponseSpec(
            "kg/m^3",
            "mass / volume under the piston at max_stress",
            upper=MAX_BULK_DENSITY,
            lab_spread_share=BULK_DENSITY_LAB_SHARE,
        ),
        "loading_modulus": ResponseSpec(
            "Pa",
            "slope of stress against strain while loading, modulus_band_lower to 1 of max_stress",
            lab_spread_share=MODULUS_LAB_SHARE,
        ),
        "unloading_modulus": ResponseSpec(
            "Pa",
            "slope of stress against strain while unloading, from max_stress down to "
            "modulus_band_lower of it",
            lab_spread_share=MODULUS_LAB_SHARE,
        ),
    },
    settings={
        **psd_settings(2.0e-3, 0.0, 2.0),
        "cylinder_diameter": SettingSpec(
            0.025, "m", "inner diameter of the cylinder", 1.0e-3, 10.0
        ),
        "fill_height": SettingSpec(
            0.025,
            "m",
            f"height of the poured fill (at a solid fraction of {FILL_SOLID_FRACTION:g})",
            1.0e-3,
            10.0,
        ),
        "seating_stress": SettingSpec(
            1.0e3,
            "Pa",
            "stress of the seating load: strain counts from it, unloading ends at it",
            1.0,
            1.0e8,
        ),
        "max_stress": SettingSpec(
            1.0e4, "Pa", "stress the piston loads the material to", 10.0, 1.0e8
        ),
        "piston_speed": SettingSpec(
            5.0e-3, "m/s", "speed of the piston, down and back", 1.0e-5, 1.0
        ),
        "modulus_band_lower": SettingSpec(
            0.5,
            "-",
            "the moduli are fitted from this share of max_stress up to max_stress",
            0.05,
            0.9,
        ),
        **settling_settings(2.0, "simulated time limit of the settling before the piston"),
    },
    analytic_model=analytic_model,
    extractors={
        "seated_bulk_density": _seated_bulk_density,
        "compressed_bulk_density": _compressed_bulk_density,
        "loading_modulus": _loading_modulus,
        "unloading_modulus": _unloading_modulus,
    },
    drivers={"lammps": f"{__name__}.lammps:run"},
    check_settings=check_settings,
    size_setting="fill_height",
    coarse=coarse_fill,
)

#: A tiny compression, seconds per LAMMPS run (3 mm spheres in a cylinder of 8 of them, filled
#: to 5, about 310 spheres): the settings of the scene's tests.
TINY_SETTINGS = {
    "d50": 3.0e-3,
    "cylinder_diameter": 0.0245,
    "fill_height": 0.0155,
    "max_settle_time": 0.5,
}
