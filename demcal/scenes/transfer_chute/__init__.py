"""Transfer chute with a flow divider (Samuelsson 2023, sec. 4.3): a design case, not a lab test.

A feed belt throws material into a funnel; the funnel drops it onto a
divider, a vertical plate between a left and a right chute. The design
question is where to put the funnel, and how fast to run the belt, so that
the flow splits evenly. The thesis' four design variables are scene settings
a study may free: the funnel's angle φ about its pivot, its offsets in y and
z, and the belt speed v.

Layout [m], y horizontal along the belt and across the divider (left y < 0,
right y > 0), x across the belt, z up; z = 0 is the plane below which the
material counts as delivered:

- feed belt: its carrying side at ``belt_height``, ending at y = −``belt_reach``;
  material is generated on it at ``feed_rate`` and moves with it at
  ``belt_speed`` towards +y. LAMMPS walls cannot move along their own
  surface, so the carrying side is a frictionless plate on which the
  material slides at the belt speed, as it rides a belt without slip; it
  leaves the belt's end at that speed.
- funnel: a cone of ``funnel_top_radius`` narrowing to ``funnel_outlet_radius``
  over ``funnel_depth``, its top centre (the pivot) at y = ``funnel_y``, z =
  ``funnel_height`` + ``funnel_z``, tilted by ``funnel_angle`` about the x axis
  through the pivot (positive: the outlet towards +y, the right).
- divider: a plate of ``divider_thickness`` in the plane y = 0, from z = 0 up
  to ``divider_height``.

Responses, from the mass that passes below z = 0 on each side over the
steady window [``steady_from``, ``feed_time``]:

- ``mass_flow_left``, ``mass_flow_right`` [kg/s]: delivered mass per second;
- ``flow_difference`` [kg/s]: left minus right (the thesis' objective is its
  absolute value; a target of 0 on it minimises its square);
- ``split`` [–]: the left share of the delivered flow (0.5 is even).

The first half of the window gives the early estimates of all four.

Sizing: the thesis' machine (offsets ±0.4 m, belt 3–4 m/s, particles 20–100 mm
with mean 50 mm) with a lognormal PSD of d50 50 mm, sigma_ln 0.25, cut at
2 sigma (30–82 mm); the thesis' rubber belt and steel funnel become one
particle–wall material. Its particle-size distribution distance response,
dropped by the thesis as redundant with the flows, is left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import norm

from demcal.errors import ConfigError
from demcal.physics.psd import diameter_range
from demcal.scenes.base import (
    MATERIAL_PARAMETERS,
    ResponseSpec,
    Scene,
    SettingSpec,
    psd_settings,
)
from demcal.scenes.transfer_chute.analytic import analytic_model

#: The design variables of the thesis (Table 4.7), as settings a study may free.
DESIGN_SETTINGS = ("funnel_angle", "funnel_y", "funnel_z", "belt_speed")
#: Width of the moving window the mass flows over time are taken over [s].
HISTORY_WINDOW = 0.2
#: Spare particles sampled beyond the expected count of the feed (the PSD's mean mass is
#: that of the sample only on average).
FEED_MARGIN = 1.25


@dataclass(frozen=True)
class ChuteGeometry:
    """Where the parts are [m] (see the module's layout)."""

    belt_height: float
    belt_reach: float
    belt_length: float
    belt_width: float
    pivot_y: float
    pivot_z: float
    tilt: float  # rad, about +x through the pivot
    funnel_depth: float
    top_radius: float
    outlet_radius: float
    divider_height: float
    divider_thickness: float
    half_width: float  # the chute's side walls at x = +-half_width

    @property
    def outlet_y(self) -> float:
        """y of the outlet's centre: below the pivot, moved by the tilt."""
        return self.pivot_y + self.funnel_depth * math.sin(self.tilt)

    @property
    def outlet_z(self) -> float:
        return self.pivot_z - self.funnel_depth * math.cos(self.tilt)


def chute_geometry(settings: dict[str, Any]) -> ChuteGeometry:
    s = settings
    return ChuteGeometry(
        belt_height=s["belt_height"],
        belt_reach=s["belt_reach"],
        belt_length=s["belt_length"],
        belt_width=s["belt_width"],
        pivot_y=s["funnel_y"],
        pivot_z=s["funnel_height"] + s["funnel_z"],
        tilt=math.radians(s["funnel_angle"]),
        funnel_depth=s["funnel_depth"],
        top_radius=s["funnel_top_radius"],
        outlet_radius=s["funnel_outlet_radius"],
        divider_height=s["divider_height"],
        divider_thickness=s["divider_thickness"],
        half_width=max(s["belt_width"] / 2.0, s["funnel_top_radius"]) + 0.1,
    )


def expected_particle_mass(settings: dict[str, Any], density: float) -> float:
    """Mean mass [kg] of a sphere of the scene's truncated lognormal PSD: ρ π/6 d50³ E[e^(3σZ)]
    with Z standard normal cut at ±k, E = e^(4.5σ²) (Φ(k−3σ) − Φ(−k−3σ)) / (Φ(k) − Φ(−k))."""
    d50: float = settings["d50"]
    sigma, k = settings["sigma_ln"], settings["psd_truncation"]
    shift = 3.0 * sigma
    cube: float = (
        math.exp(0.5 * shift * shift)
        * (norm.cdf(k - shift) - norm.cdf(-k - shift))
        / (norm.cdf(k) - norm.cdf(-k))
    )
    return density * math.pi / 6.0 * d50**3 * cube


def flow_history(
    state: dict[str, np.ndarray], settings: dict[str, Any]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The mass flows left and right [kg/s] over time: the delivered mass over the last
    ``HISTORY_WINDOW`` (at least one count) before each count, per second (the thesis'
    Figure 5.5b)."""
    times = np.asarray(state["delivery_time"], float)
    lag = max(1, round(HISTORY_WINDOW / settings["sample_interval"]))
    span = times[lag:] - times[:-lag]
    return {
        side: (times[lag:], (delivered[lag:] - delivered[:-lag]) / span)
        for side, delivered in (
            ("mass_flow_left", np.asarray(state["delivered_left"], float)),
            ("mass_flow_right", np.asarray(state["delivered_right"], float)),
        )
    }


def check_chute(settings: dict[str, Any], field_prefix: str) -> None:
    """Cross-setting checks: the outlet passes the largest particles, the steady window
    lies in the feed, and no part of the funnel reaches the belt or the divider."""
    s = settings
    _, d_max = diameter_range(s["d50"], s["sigma_ln"], s["psd_truncation"])
    if 2.0 * s["funnel_outlet_radius"] < 4.0 * d_max:
        raise ConfigError(
            f"{field_prefix}.funnel_outlet_radius: {s['funnel_outlet_radius']:g} m; the outlet "
            f"must be at least 4 of the largest particles ({d_max:g} m) wide, a radius of "
            f"{2.0 * d_max:g} m"
        )
    if s["funnel_outlet_radius"] >= s["funnel_top_radius"]:
        raise ConfigError(
            f"{field_prefix}.funnel_outlet_radius: {s['funnel_outlet_radius']:g} m is not "
            f"below funnel_top_radius ({s['funnel_top_radius']:g} m)"
        )
    if s["steady_from"] >= s["feed_time"]:
        raise ConfigError(
            f"{field_prefix}.steady_from: {s['steady_from']:g} s leaves no steady window "
            f"before feed_time ({s['feed_time']:g} s) ends"
        )
    g = chute_geometry(s)
    rim = g.pivot_z + g.top_radius * abs(math.sin(g.tilt))
    if rim >= g.belt_height - d_max:
        raise ConfigError(
            f"{field_prefix}.funnel_height: the funnel's rim reaches z = {rim:g} m, into the "
            f"belt at {g.belt_height:g} m; lower funnel_height or funnel_z"
        )
    outlet_low = g.outlet_z - g.outlet_radius * abs(math.sin(g.tilt))
    if outlet_low <= g.divider_height + 2.0 * d_max:
        raise ConfigError(
            f"{field_prefix}.divider_height: the funnel's outlet comes down to z = "
            f"{outlet_low:g} m, within two particles of the divider's top at "
            f"{g.divider_height:g} m; raise funnel_height or lower divider_height"
        )


def shorter_window(settings: dict[str, Any]) -> dict[str, Any]:
    """The default coarse level: the flows averaged over half the steady window, the feed
    ending that much sooner (larger particles would soon block the funnel's outlet)."""
    return {"feed_time": 0.5 * (settings["steady_from"] + settings["feed_time"])}


SCENE = Scene(
    name="transfer_chute",
    description="feed belt, tilting funnel and divider: the mass flow left and right "
    "(Samuelsson 2023, case 2)",
    parameters=MATERIAL_PARAMETERS,
    responses={
        "mass_flow_left": ResponseSpec("kg/s", "mass delivered left of the divider per second"),
        "mass_flow_right": ResponseSpec("kg/s", "mass delivered right of the divider per second"),
        "flow_difference": ResponseSpec(
            "kg/s", "left minus right mass flow", lower=-math.inf, upper=math.inf
        ),
        "split": ResponseSpec("-", "left share of the delivered mass flow", upper=1.0),
    },
    settings={
        **psd_settings(0.05, 0.25, 2.0),
        "funnel_angle": SettingSpec(
            0.0,
            "deg",
            "tilt of the funnel about its pivot, + towards the right",
            -30.0,
            30.0,
            variable=True,
        ),
        "funnel_y": SettingSpec(
            0.0,
            "m",
            "offset of the funnel's pivot from the divider's plane",
            -1.0,
            1.0,
            variable=True,
        ),
        "funnel_z": SettingSpec(
            0.0, "m", "offset of the funnel's pivot from funnel_height", -1.0, 1.0, variable=True
        ),
        "belt_speed": SettingSpec(3.5, "m/s", "speed of the feed belt", 0.5, 10.0, variable=True),
        "feed_rate": SettingSpec(150.0, "kg/s", "mass fed onto the belt per second", 1.0, 1.0e4),
        "feed_time": SettingSpec(3.0, "s", "simulated time of feeding (the run's end)", 0.2, 100.0),
        "steady_from": SettingSpec(
            1.2, "s", "start of the window the flows are averaged over", 0.0, 100.0
        ),
        "sample_interval": SettingSpec(
            0.05, "s", "time between counts of the delivered mass", 1.0e-3, 1.0
        ),
        "belt_height": SettingSpec(2.1, "m", "height of the belt's carrying side", 0.5, 20.0),
        "belt_reach": SettingSpec(
            1.0, "m", "distance from the belt's end to the divider's plane", 0.0, 10.0
        ),
        "belt_length": SettingSpec(0.6, "m", "length of the belt simulated", 0.2, 10.0),
        "belt_width": SettingSpec(0.5, "m", "width between the belt's skirts", 0.1, 5.0),
        "funnel_height": SettingSpec(1.5, "m", "height of the funnel's pivot (its top)", 0.3, 20.0),
        "funnel_depth": SettingSpec(0.5, "m", "height of the funnel's cone", 0.1, 5.0),
        "funnel_top_radius": SettingSpec(0.5, "m", "radius of the funnel's top", 0.05, 5.0),
        "funnel_outlet_radius": SettingSpec(0.2, "m", "radius of the funnel's outlet", 0.02, 5.0),
        "divider_height": SettingSpec(0.3, "m", "height of the divider's top", 0.05, 10.0),
        "divider_thickness": SettingSpec(0.02, "m", "thickness of the divider", 1.0e-3, 1.0),
        "dump_interval": SettingSpec(
            0.0, "s", "simulated time between particle dumps (dump.lammpstrj); 0 = none", 0.0, 10.0
        ),
    },
    analytic_model=analytic_model,
    drivers={"lammps": f"{__name__}.lammps:run"},
    check_settings=check_chute,
    size_setting="feed_rate",
    history=flow_history,
    coarse=shorter_window,
)
