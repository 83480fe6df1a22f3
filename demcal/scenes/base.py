"""What a scene (a lab test) declares: parameters it reads, settings, responses."""

from __future__ import annotations

import ast
import hashlib
import math
import pkgutil
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from demcal.errors import ConfigError
from demcal.physics.catalogue import CATALOG, ParameterSpec
from demcal.physics.contact import bond_number
from demcal.physics.psd import diameter_range, mean_sphere_volume

if TYPE_CHECKING:
    import numpy as np

#: Largest possible angle of a slope (repose, shear), deg.
MAX_ANGLE = 90.0
#: A bulk density cannot exceed the solid density of its particles (the
#: catalogue's largest), kg/m^3.
MAX_BULK_DENSITY = CATALOG["particle_density"].upper
#: demcal's assumed scatter of single lab tests where the user gives none (``demcal advise``;
#: docs/advise.md): an angle of a heap or slope [deg], and shares of the measured value.
ANGLE_LAB_SPREAD = 1.5
BULK_DENSITY_LAB_SHARE = 0.01
MASS_FLOW_LAB_SHARE = 0.03
SLIDE_TIME_LAB_SHARE = 0.05


def saturating(value: float, scale: float) -> float:
    """1 - exp(-value / scale): 0 at 0, rising to 1; a building block of the analytic models."""
    return 1.0 - math.exp(-value / scale)


def adhesion(p: dict[str, float], settings: dict[str, Any]) -> float:
    """The analytic stand-ins' measure of particle-particle adhesion: 0 without (also where
    the surface energy is not given: the catalogue's default, cohesionless), rising to 1
    with the Bond number (`bond_number`; about 1 where adhesion starts to matter)."""
    gamma = p.get("surface_energy_pp", CATALOG["surface_energy_pp"].default)
    if gamma == 0.0:
        return 0.0
    return saturating(bond_number(gamma, settings["d50"], p["particle_density"]), 5.0)


#: Modules whose names only serve type annotations: importing from them changes no outcome.
TYPING_MODULES = ("__future__", "typing", "collections.abc", "numpy.typing")


class _CodeOnly(ast.NodeTransformer):
    """A syntax tree without what cannot change a result: docstrings, type annotations (an
    annotated name stays declared), ``if TYPE_CHECKING:`` blocks and imports of typing names."""

    def visit_Module(self, node: ast.Module) -> ast.AST:
        return self._without_docstring(node)

    def visit_ClassDef(self, node: ast.ClassDef) -> ast.AST:
        return self._without_docstring(node)

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:
        node.returns = None
        return self._without_docstring(node)

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> ast.AST:
        node.returns = None
        return self._without_docstring(node)

    def visit_arg(self, node: ast.arg) -> ast.AST:
        node.annotation = None
        return node

    def visit_AnnAssign(self, node: ast.AnnAssign) -> ast.AST:
        node.annotation = ast.Constant(None)
        return self.generic_visit(node)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> ast.AST | None:
        return None if node.module in TYPING_MODULES else node

    def visit_If(self, node: ast.If) -> ast.AST | None:
        return (
            None if ast.unparse(node.test).endswith("TYPE_CHECKING") else self.generic_visit(node)
        )

    def _without_docstring(
        self, node: ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef
    ) -> ast.AST:
        body = node.body
        if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            node.body = body[1:] or [ast.Pass()]
        return self.generic_visit(node)


def code_digest(path: Path) -> str:
    """sha256 of a Python file's code: its syntax tree without docstrings, comments, type
    annotations and layout (`_CodeOnly`), so that only an edit that can change what the code
    does changes it."""
    tree = _CodeOnly().visit(ast.parse(path.read_text(), str(path)))
    return hashlib.sha256(ast.dump(tree).encode()).hexdigest()


def _module_file(name: str) -> str | None:
    """The source file of the imported module ``name`` (None if it has none)."""
    return getattr(sys.modules.get(name), "__file__", None)


@dataclass(frozen=True)
class SettingSpec:
    """A scene setting (geometry, particle size, lift speed...): default and allowed values."""

    default: object
    unit: str
    description: str
    lower: float | None = None
    upper: float | None = None
    choices: tuple[object, ...] | None = None
    integer: bool = False
    #: a study may make it free, with bounds, beside the material parameters (``parameters:``)
    variable: bool = False

    def allowed(self) -> str:
        if self.choices is not None:
            return "one of " + ", ".join(map(str, self.choices))
        kind = "an integer" if self.integer else "a number"
        lo = "-inf" if self.lower is None else f"{self.lower:g}"
        hi = "inf" if self.upper is None else f"{self.upper:g}"
        unit = "" if self.unit == "-" else self.unit
        return f"{kind} in [{lo}, {hi}] {unit}".rstrip()

    def check(self, field_name: str, value: object) -> object:
        """Return ``value`` if allowed, else raise ConfigError naming field, value and range."""
        if self.choices is not None:
            if value not in self.choices:
                raise ConfigError(f"{field_name}: {value!r} is not allowed; use {self.allowed()}")
            return value
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or (self.integer and not float(value).is_integer())
        ):
            raise ConfigError(f"{field_name}: {value!r} is not {self.allowed()}")
        if (self.lower is not None and value < self.lower) or (
            self.upper is not None and value > self.upper
        ):
            raise ConfigError(
                f"{field_name}: {value!r} is outside the allowed range: {self.allowed()}"
            )
        return int(value) if self.integer else float(value)


#: The material parameters every scene reads (names in demcal.physics.catalogue): contact
#: friction, rolling resistance, restitution and adhesion (surface energy) between particles
#: (pp) and with walls (pw), the rolling damping ratio, stiffness and particle density.
MATERIAL_PARAMETERS = (
    "sliding_friction_pp",
    "sliding_friction_pw",
    "rolling_friction_pp",
    "rolling_friction_pw",
    "restitution_pp",
    "restitution_pw",
    "rolling_damping_ratio",
    "youngs_modulus",
    "poisson_ratio",
    "surface_energy_pp",
    "surface_energy_pw",
    "particle_density",
)


def variable_settings(scenes: Iterable[Scene]) -> dict[str, ParameterSpec]:
    """The settings of ``scenes`` that a study may make free, as parameters: a setting several
    scenes declare may take the values all of them allow."""
    found: dict[str, ParameterSpec] = {}
    for scene in scenes:
        for name, spec in scene.settings.items():
            if not spec.variable:
                continue
            assert (
                spec.lower is not None
                and spec.upper is not None
                and isinstance(spec.default, float)
            ), f"variable setting {scene.name}.{name} needs a numeric range and default"
            known = found.get(name)
            lower = spec.lower if known is None else max(known.lower, spec.lower)
            upper = spec.upper if known is None else min(known.upper, spec.upper)
            found[name] = ParameterSpec(
                name, spec.unit, lower, upper, spec.default, spec.description, scene_setting=True
            )
    return found


def psd_settings(
    d50: float, sigma_ln: float, truncation: float, sigma_upper: float = 1.0, d50_note: str = ""
) -> dict[str, SettingSpec]:
    """The lognormal particle-size distribution every scene reads: its median diameter d50 and
    the sd of ln(diameter) are variable, as Richter & Will (2021) vary them; the cut is not."""
    return {
        "d50": SettingSpec(
            d50, "m", f"median particle diameter{d50_note}", 1.0e-5, 0.1, variable=True
        ),
        "sigma_ln": SettingSpec(
            sigma_ln,
            "-",
            "std. dev. of ln(diameter); 0 = monodisperse",
            0.0,
            sigma_upper,
            variable=True,
        ),
        "psd_truncation": SettingSpec(
            truncation, "sigma", "lognormal cut at d50 exp(+-k sigma_ln)", 0.5, 4.0
        ),
    }


def spheres_to_fill(volume: float, settings: dict[str, Any], solid_fraction: float) -> int:
    """How many spheres of the scene's particle-size distribution fill ``volume`` [m^3] at
    ``solid_fraction``."""
    sphere = mean_sphere_volume(settings["d50"], settings["sigma_ln"], settings["psd_truncation"])
    return round(solid_fraction * volume / sphere)


def check_sizes_in_particles(
    settings: dict[str, Any], field_prefix: str, smallest: dict[str, float]
) -> None:
    """Refuse a length setting below its ``smallest`` multiple of the largest particle."""
    _, d_max = diameter_range(settings["d50"], settings["sigma_ln"], settings["psd_truncation"])
    for name, multiple in smallest.items():
        if settings[name] < multiple * d_max:
            raise ConfigError(
                f"{field_prefix}.{name}: {settings[name]:g} m is less than {multiple:g} of the "
                f"largest particles ({d_max:g} m); use at least {multiple * d_max:g} m"
            )


#: The settings that describe the material rather than the test (its particle sizes): what a
#: second test of the same material takes over from the first (``demcal advise``).
MATERIAL_SETTINGS = tuple(psd_settings(1.0e-3, 0.0, 1.0))


def settling_settings(max_settle_time: float, meaning: str) -> dict[str, SettingSpec]:
    """The settings every scene shares: when material counts as at rest (rms speed), how long
    a settling stage may take (simulated s, ``meaning`` says which stages), and particle dumps
    for viewing."""
    return {
        "rest_speed": SettingSpec(
            5.0e-3, "m/s", "rms particle speed below which material is at rest", 1.0e-6, 1.0
        ),
        "max_settle_time": SettingSpec(max_settle_time, "s", meaning, 0.01, 100.0),
        "dump_interval": SettingSpec(
            0.0,
            "s",
            "simulated time between particle dumps (dump.lammpstrj, for viewing); 0 = no dumps",
            0.0,
            100.0,
        ),
    }


#: The default coarse level of a scene with a particle count: this many times fewer particles.
COARSE_PARTICLE_FACTOR = 4


def fewer_particles(settings: dict[str, Any], count: float) -> dict[str, Any]:
    """The settings that make a scene's fill ``count`` particles of the same amount of
    material: the particle count, and d50 scaled by (N0 / N)^(1/3), so that the geometry and
    the volume stay and only the resolution changes."""
    return {
        "particle_count": round(count),
        "d50": settings["d50"] * (settings["particle_count"] / round(count)) ** (1.0 / 3.0),
    }


def coarse_by_particle_count(settings: dict[str, Any]) -> dict[str, Any]:
    """The default coarse level of a scene with a ``particle_count``: COARSE_PARTICLE_FACTOR
    times fewer, larger particles of the same amount of material (`fewer_particles`)."""
    return fewer_particles(settings, settings["particle_count"] / COARSE_PARTICLE_FACTOR)


@dataclass(frozen=True)
class ResponseSpec:
    """A bulk response a scene can produce, in ``unit``, physically between
    ``lower`` and ``upper``.

    ``lab_spread`` is the typical standard deviation of single lab tests of it, in its unit,
    or ``lab_spread_share`` the same as a share of the measured value: the measurement
    spread ``demcal advise`` assumes for a test the user has not measured yet
    (docs/advise.md). A response with neither is no lab measurement (a design case's).
    """

    unit: str
    description: str
    lower: float = 0.0
    upper: float = math.inf
    lab_spread: float | None = None
    lab_spread_share: float | None = None

    def typical_spread(self, value: float) -> float | None:
        """The typical lab-test spread of a measured ``value`` of this response (None: not a
        lab measurement)."""
        if self.lab_spread is not None:
            return self.lab_spread
        if self.lab_spread_share is not None:
            return self.lab_spread_share * abs(value)
        return None


@dataclass(frozen=True)
class Scene:
    """Declaration of a lab test.

    ``analytic_model(parameters, settings) -> {response: value}`` is a
    closed-form stand-in, the analytic test engine's driver; ``drivers`` maps
    another engine's name to the import path ("module:attribute") of what runs
    this scene on that engine (``driver``); ``extractors`` compute a response
    from the saved particle state (``extract(state, settings)``).
    """

    name: str
    description: str
    parameters: tuple[str, ...]
    responses: dict[str, ResponseSpec]
    settings: dict[str, SettingSpec]
    analytic_model: Callable[[dict[str, float], dict[str, Any]], dict[str, float]]
    extractors: dict[str, Callable[[dict[str, np.ndarray], dict[str, Any]], float]] = field(
        default_factory=dict
    )
    drivers: dict[str, str] = field(default_factory=dict)
    #: Cross-setting checks a single range cannot express: (settings, field prefix) -> None.
    check_settings: Callable[[dict[str, Any], str], None] | None = None
    #: The setting that sets the simulated amount of material (particle count or a scale
    #: factor), varied by the convergence study.
    size_setting: str = "particle_count"
    #: The scene's default coarse level (``fidelities: {coarse: default}``): (fine settings)
    #: -> the settings it changes; None: the scene has none (give the level's settings).
    coarse: Callable[[dict[str, Any]], dict[str, Any]] | None = None
    #: Responses over simulated time from a run's saved state, for the report's figure of
    #: the answer: (state, settings) -> {response: (times [s], values)}; None: the scene has
    #: no time series worth showing.
    history: (
        Callable[[dict[str, np.ndarray], dict[str, Any]], dict[str, tuple[np.ndarray, np.ndarray]]]
        | None
    ) = None

    @property
    def lab_test(self) -> bool:
        """Whether the scene is a lab test (every response has a typical lab spread), one
        ``demcal advise`` may propose, rather than a design case."""
        return all(
            spec.lab_spread is not None or spec.lab_spread_share is not None
            for spec in self.responses.values()
        )

    def driver(self, engine: str) -> Callable[..., Any] | None:
        """What the engine named ``engine`` runs for this scene; None if the scene has none.

        The analytic engine gets ``analytic_model``; any other engine the
        object its ``drivers`` entry names, imported now.
        """
        if engine == "analytic":
            return self.analytic_model
        path = self.drivers.get(engine)
        return None if path is None else pkgutil.resolve_name(path)

    def script_digests(self, engine: str) -> list[str]:
        """The code digest (`code_digest`) of each source file of what runs and measures this
        scene on ``engine``, sorted: its driver's and extractors' modules and, for a scene that
        is a package, every other module of it that is no other engine's driver (what they
        share, such as the drum's regime). A scene script whose code is edited is another
        simulator; one whose types, docstrings or comments are is not."""
        used = {
            getattr(function, "__module__", "")
            for function in (self.driver(engine), *self.extractors.values())
            if function is not None
        }
        files = {Path(path) for name in used if (path := _module_file(name))}
        package = self.analytic_model.__module__.rpartition(".")[0]
        init = _module_file(package)
        if init and Path(init).name == "__init__.py":
            others = {path.partition(":")[0] for name, path in self.drivers.items()}
            others -= {self.drivers.get(engine, "").partition(":")[0]}
            if engine != "analytic":
                others.add(self.analytic_model.__module__)
            files |= {
                file
                for file in Path(init).parent.glob("*.py")
                if f"{package}.{file.stem}" not in others
            }
        return sorted(code_digest(file) for file in files)

    def resolve_settings(self, given: dict[str, Any] | None, field_prefix: str) -> dict[str, Any]:
        """Defaults overlaid with the given settings, each checked against its spec."""
        given = dict(given or {})
        unknown = sorted(set(given) - set(self.settings))
        if unknown:
            raise ConfigError(
                f"{field_prefix}.{unknown[0]}: unknown setting for scene {self.name!r}; "
                f"known settings: {', '.join(sorted(self.settings))}"
            )
        resolved = {
            name: spec.check(f"{field_prefix}.{name}", given.get(name, spec.default))
            for name, spec in self.settings.items()
        }
        if self.check_settings is not None:
            self.check_settings(resolved, field_prefix)
        return resolved
