"""Shear box test (Richter & Will 2021, sec. 3.5, after Rössler et al.): bulk density and
shear angle.

Not a direct shear cell: a box is filled with material, one end wall (the
flap) is opened, and the material flows out until the rest stands in the box
with a slope falling towards the opening. Richter & Will take the shear angle
from a straight line through the uppermost particles of that slope and the
bulk density from the mass in the filled box over the box volume.

Scaling (their eq. 4): Rössler et al.'s box (length 100 mm along the outflow,
width 100 mm, height 150 mm) is scaled by S = 10 d_max / min(l, w, h), so
its smallest side is ten largest particles: the particle count does not
change with d50 (only with the width of the PSD) and the shear angle does
not depend on d50. Here the ten is the setting ``box_size_dmax`` and the
base box is a setting too.

Filling (a choice: the paper does not describe it): spheres enough to fill
the box at the densest random packing are generated above the floor inside
the box walls, fall and settle; then every sphere whose centre lies above
the box top is removed (struck off). Bulk density = mass of the spheres
whose centres lie inside the box / box volume. The flap is then removed at
once; spheres that leave over the floor's edge fall away and are deleted.

Defaults: Richter & Will's gravel 8/16 (Table 3: d50 11.16 mm, sigma_ln
0.26); a cut at 1.5 sigma gives 7.6-16.5 mm, the sieve range. The PSD is
sampled by number (``demcal.physics.psd``); Richter & Will fit the lognormal
to the mass distribution Q3, whose median is exp(3 sigma_ln^2) times the
number median: convert d50 before entering a sieve analysis here. About
5000 spheres are generated at the defaults, 4600 stay in the struck-off box.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from demcal.errors import ConfigError
from demcal.physics import measure
from demcal.physics.psd import diameter_range, mean_sphere_volume
from demcal.scenes.base import (
    ANGLE_LAB_SPREAD,
    BULK_DENSITY_LAB_SHARE,
    MATERIAL_PARAMETERS,
    MAX_ANGLE,
    MAX_BULK_DENSITY,
    ResponseSpec,
    Scene,
    SettingSpec,
    psd_settings,
    settling_settings,
)
from demcal.scenes.shear_box.analytic import analytic_model

#: Spheres generated fill the box at a solid fraction above the densest random packing of
#: the PSDs a study uses (0.64 for equal spheres, about 0.68 for a lognormal of sigma_ln 0.4;
#: at 0.64, a campaign lost a run with sigma_ln 0.38), so the settled fill reaches above the
#: box top before it is struck off.
FILL_SOLID_FRACTION = 0.70
#: Fewest surface columns of width d50 along the box for a slope fit.
MIN_SLOPE_COLUMNS = 5
#: Most spheres a box may need: the count grows with the PSD's width, as
#: (d_max / d50)^3 (about 5000 at the defaults).
MAX_PARTICLES = 100_000
#: The smallest box allowed, in largest particle diameters.
BOX_SIZE_DMAX_MIN = 4.0


def box_dimensions(settings: dict[str, Any]) -> tuple[float, float, float]:
    """Inner length (outflow direction), width and height of the scaled box [m] (eq. 4)."""
    _, d_max = diameter_range(settings["d50"], settings["sigma_ln"], settings["psd_truncation"])
    base = (settings["base_length"], settings["base_width"], settings["base_height"])
    scale = settings["box_size_dmax"] * d_max / min(base)
    return tuple(scale * side for side in base)


def fill_particle_count(settings: dict[str, Any]) -> int:
    """Spheres generated: enough to fill the box at ``FILL_SOLID_FRACTION``."""
    length, width, height = box_dimensions(settings)
    return math.ceil(
        FILL_SOLID_FRACTION
        * length
        * width
        * height
        / mean_sphere_volume(settings["d50"], settings["sigma_ln"], settings["psd_truncation"])
    )


def _bulk_density(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    return measure.box_bulk_density(state["fill_x"], state["fill_mass"], box_dimensions(settings))


def _shear_angle(state: dict[str, np.ndarray], settings: dict[str, Any]) -> float:
    length, _, _ = box_dimensions(settings)
    return measure.box_slope_angle(
        state["slope_x"],
        state["slope_r"],
        settings["d50"],
        length,
        (settings["angle_band_lower"], settings["angle_band_upper"]),
    )


def check_settings(settings: dict[str, Any], field_prefix: str) -> None:
    """Cross-setting checks a single range cannot express."""
    if settings["angle_band_lower"] >= settings["angle_band_upper"]:
        raise ConfigError(
            f"{field_prefix}.angle_band_lower: {settings['angle_band_lower']:g} must be below "
            f"angle_band_upper ({settings['angle_band_upper']:g})"
        )
    length, _, _ = box_dimensions(settings)
    columns = length / settings["d50"]
    if columns < MIN_SLOPE_COLUMNS:
        raise ConfigError(
            f"{field_prefix}.box_size_dmax: the box is only {columns:.3g} median diameters "
            f"long ({length:g} m); the slope fit needs at least {MIN_SLOPE_COLUMNS}: raise "
            f"box_size_dmax"
        )
    count = fill_particle_count(settings)
    if count > MAX_PARTICLES:
        raise ConfigError(
            f"{field_prefix}.sigma_ln: the box (smallest side {settings['box_size_dmax']:g} "
            f"largest particles) needs {count} spheres of this PSD, more than {MAX_PARTICLES}; "
            f"narrow the PSD (sigma_ln, psd_truncation) or lower box_size_dmax"
        )


#: The default coarse level's box, as a share of the fine box side (0.6^3: about a fifth of the
#: particles).
COARSE_BOX_SHARE = 0.6


def coarse_box(settings: dict[str, Any]) -> dict[str, Any]:
    """The default coarse level: a box COARSE_BOX_SHARE of the side in largest particles
    (Richter & Will's scale factor), at least the smallest box allowed."""
    return {"box_size_dmax": max(BOX_SIZE_DMAX_MIN, COARSE_BOX_SHARE * settings["box_size_dmax"])}


SCENE = Scene(
    name="shear_box",
    description="shear box test (Richter & Will 2021): bulk density of the filled box and "
    "shear angle of the material left after the flap opens",
    parameters=MATERIAL_PARAMETERS,
    responses={
        "bulk_density": ResponseSpec(
            "kg/m^3",
            "mass of the spheres whose centres lie in the filled, struck-off box / box volume",
            upper=MAX_BULK_DENSITY,
            lab_spread_share=BULK_DENSITY_LAB_SHARE,
        ),
        "shear_angle": ResponseSpec(
            "deg",
            "slope of the material left in the box after the "
            "flap opened: line fit of the surface against the "
            "distance along the box",
            upper=MAX_ANGLE,
            lab_spread=ANGLE_LAB_SPREAD,
        ),
    },
    settings={
        **psd_settings(11.16e-3, 0.26, 1.5, sigma_upper=1.2, d50_note=" (by number)"),
        "box_size_dmax": SettingSpec(
            10.0,
            "d_max",
            "smallest inner box side in largest particle diameters (Richter & Will: 10)",
            BOX_SIZE_DMAX_MIN,
            40.0,
        ),
        "base_length": SettingSpec(
            0.10,
            "m",
            "unscaled box length along the outflow (Rössler et al.: 100 mm)",
            1.0e-3,
            10.0,
        ),
        "base_width": SettingSpec(0.10, "m", "unscaled box width (100 mm)", 1.0e-3, 10.0),
        "base_height": SettingSpec(0.15, "m", "unscaled box height (150 mm)", 1.0e-3, 10.0),
        **settling_settings(5.0, "simulated time limit of the fill and of the outflow"),
        "angle_band_lower": SettingSpec(
            0.2, "-", "slope fit: lowest surface height, fraction of the highest", 0.0, 0.9
        ),
        "angle_band_upper": SettingSpec(
            0.8, "-", "slope fit: highest surface height, fraction of the highest", 0.1, 1.0
        ),
    },
    analytic_model=analytic_model,
    extractors={"bulk_density": _bulk_density, "shear_angle": _shear_angle},
    drivers={"lammps": f"{__name__}.lammps:run"},
    check_settings=check_settings,
    size_setting="box_size_dmax",
    coarse=coarse_box,
)

#: A tiny shear box, seconds per LAMMPS run (monodisperse 3 mm spheres, the box's smallest
#: side five of them): the settings of the scene's tests and of the benchmarks' quick real runs.
TINY_SETTINGS = {"d50": 3.0e-3, "sigma_ln": 0.0, "box_size_dmax": 5.0, "max_settle_time": 2.0}
