"""Catalogue of the DEM material parameters demcal knows.

One place for each fact: a parameter's unit, physically allowed range and
default value live here; scenes list which of them they read, and the study
config chooses which are free (with bounds inside the allowed range) and
which are fixed.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ParameterSpec:
    """A material parameter: SI unit, physically allowed closed range, default."""

    name: str
    unit: str
    lower: float
    upper: float
    default: float
    description: str

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
            "restitution", "-", 0.01, 1.0, 0.5, "normal coefficient of restitution (all contacts)"
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
            "particle_density",
            "kg/m^3",
            100.0,
            20000.0,
            2500.0,
            "solid density of the particle material",
        ),
    )
}
