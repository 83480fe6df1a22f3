"""Catalogue of the DEM material parameters demcal knows.

One place for each fact: a parameter's unit, physically allowed range and
default value live here; scenes list which of them they read, and the study
config chooses which are free (with bounds inside the allowed range) and
which are fixed.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ParameterSpec:
    """A quantity a study may make free: SI unit, physically allowed closed range, default.

    A material parameter of the catalogue below, or a scene setting that the study's scenes
    declare variable (``scene_setting``: the particle-size distribution's d50 and sigma_ln;
    ``demcal.scenes.base.variable_settings``).
    """

    name: str
    unit: str
    lower: float
    upper: float
    default: float
    description: str
    scene_setting: bool = False

    def allowed(self) -> str:
        """The allowed range as text for error messages."""
        return f"[{self.lower:g}, {self.upper:g}] {'' if self.unit == '-' else self.unit}".rstrip()

    def contains(self, value: float) -> bool:
        return self.lower <= value <= self.upper


CATALOG: dict[str, ParameterSpec] = {
    spec.name: spec
    for spec in (
        ParameterSpec(
            "sliding_friction_pp",
            "-",
            0.0,
            2.0,
            0.5,
            "sliding (Coulomb) friction coefficient, particle-particle",
        ),
        ParameterSpec(
            "sliding_friction_pw",
            "-",
            0.0,
            2.0,
            0.5,
            "sliding (Coulomb) friction coefficient, particle-wall",
        ),
        ParameterSpec(
            "rolling_friction_pp",
            "-",
            0.0,
            1.0,
            0.1,
            "rolling friction coefficient, particle-particle (torque cap mu_r R* F_n)",
        ),
        ParameterSpec(
            "rolling_friction_pw", "-", 0.0, 1.0, 0.1, "rolling friction coefficient, particle-wall"
        ),
        ParameterSpec(
            "restitution_pp",
            "-",
            0.01,
            1.0,
            0.5,
            "normal coefficient of restitution, particle-particle",
        ),
        ParameterSpec(
            "restitution_pw",
            "-",
            0.01,
            1.0,
            0.5,
            "normal coefficient of restitution, particle-wall",
        ),
        ParameterSpec(
            "rolling_damping_ratio",
            "-",
            0.0,
            1.0,
            0.3,
            "viscous damping ratio eta_r of the rolling spring, all contacts (Ai et al. 2011)",
        ),
        ParameterSpec(
            "youngs_modulus",
            "Pa",
            1.0e5,
            1.0e12,
            5.0e6,
            "Young's modulus of the particles (walls use the same material)",
        ),
        ParameterSpec("poisson_ratio", "-", 0.0, 0.49, 0.3, "Poisson's ratio of the particles"),
        ParameterSpec(
            "surface_energy_pp",
            "J/m^2",
            0.0,
            100.0,
            0.0,
            "surface energy density gamma of JKR adhesion, particle-particle (0 = cohesionless)",
        ),
        ParameterSpec(
            "surface_energy_pw",
            "J/m^2",
            0.0,
            100.0,
            0.0,
            "surface energy density gamma of JKR adhesion, particle-wall (0 = cohesionless)",
        ),
        ParameterSpec(
            "particle_density",
            "kg/m^3",
            100.0,
            20000.0,
            2500.0,
            "solid density of the particle material",
        ),
    )
}

#: Parameters that earlier versions of demcal knew under one name and that are now several:
#: one restitution for all contacts became the particle-particle and particle-wall ones.
SPLIT_PARAMETERS: dict[str, tuple[str, ...]] = {"restitution": ("restitution_pp", "restitution_pw")}
#: Parameters that earlier versions held at a constant rather than reading: what they used.
EARLIER_CONSTANTS: dict[str, float] = {
    "rolling_damping_ratio": 0.3,
    "surface_energy_pp": 0.0,
    "surface_energy_pw": 0.0,
}


def upgrade_parameters(values: dict[str, float], free: Collection[str] = ()) -> dict[str, float]:
    """The parameter values of a simulation or study recorded by an earlier demcal, in
    today's names.

    A split parameter gives each of its parts its value; a parameter that was a constant
    gets that constant unless it is among ``free`` (a study's fixed values leave out what it
    frees). Values already in today's names, or none, are returned unchanged.
    """
    if not values:
        return values
    upgraded = {name: value for name, value in values.items() if name not in SPLIT_PARAMETERS}
    for old, parts in SPLIT_PARAMETERS.items():
        if old in values:
            upgraded.update({part: values[old] for part in parts if part not in values})
    constants = {name: value for name, value in EARLIER_CONSTANTS.items() if name not in free}
    return {**constants, **upgraded}


def free_names(parameters: list[dict[str, Any]]) -> set[str]:
    """Today's names of a recorded study's free parameters (its ``parameters`` list)."""
    return {
        name
        for entry in parameters
        for name in SPLIT_PARAMETERS.get(entry["name"], (entry["name"],))
    }
