"""Global metamodels (Richter & Will 2021, secs. 2.4 and 3): one model per response over a
material domain, trained once on the archive's simulations of that domain.

The domain is a study's box (its free parameters, material ones and free scene settings);
its data are the archive's simulations compatible with the study (same scene, engine,
settings and fixed values; :meth:`demcal.study.model.Study.archive_view`), usually those of a
sampling campaign (``demcal sample``). Each targeted response gets

- ``kriging``: the per-response Kriging of the optimizer (SMT, Matérn 5/2, linear trend,
  nugget), on the unit box;
- ``symbolic``: symbolic regression by genetic programming (gplearn, as Richter & Will: the
  function set +, -, *, /, sqrt, log, exp, tanh; parsimony 0.001, population 5000), on the
  unit box and the standardised response, so its equation reads
  ``response = mean + sd * f(x_name, ...)`` with ``x_name`` the parameter scaled to [0, 1].

The models are saved under ``results/<study>/metamodels/`` with the fingerprint of the data
they were trained on, so a later command knows when the archive has moved on.
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from demcal.archive.record import digest
from demcal.archive.reuse import compatible_simulations
from demcal.archive.store import Archive
from demcal.errors import ConfigError
from demcal.study.model import Study

if TYPE_CHECKING:
    from demcal.analysis.solution_report import SolutionAnalysis

MODEL_KINDS = ("kriging", "symbolic")
#: Richter & Will's genetic-programming settings (sec. 2.4): population and parsimony.
POPULATION = 5000
PARSIMONY = 0.001
GENERATIONS = 20
#: Format of the saved models: 2 since each model gives an sd (the solution set needs it).
FORMAT = 2
#: Starts of the Kriging hyperparameter search.
KRIGING_RESTARTS = 5


@dataclass
class ResponseData:
    """The simulations of one response over the domain: inputs in SI units, one row each."""

    key: str
    x: np.ndarray
    y: np.ndarray
    sources: list[str]


@dataclass
class DomainData:
    """A domain's data: its inputs (names and bounds) and each targeted response's rows.

    ``fingerprint`` digests the archive keys of every simulation used, so models built on it
    know when the archive holds other data."""

    names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    responses: dict[str, ResponseData]
    fingerprint: str


def domain_data(
    study: Study,
    archive: Archive,
    exclude: tuple[str, ...] = (),
    only: tuple[str, ...] | None = None,
) -> DomainData:
    """The study's domain and its compatible simulations (as for reuse:
    :func:`demcal.archive.reuse.compatible_simulations`): without those of the studies
    ``exclude`` names (a held-out validation campaign), or those of the studies ``only``
    names alone. A damaged simulation is left out, or gives only its sound responses, as the
    archive reads it (:meth:`Archive.warn_damaged` names them)."""
    names = [p.name for p in study.free]
    rows: dict[str, tuple[list, list, list]] = {t.key: ([], [], []) for t in study.targets}
    records = compatible_simulations(
        study,
        archive,
        lambda name: name not in exclude and (only is None or name in only),
    )
    archive.warn_damaged()
    for record in records:
        for target in study.targets:
            if target.scene == record.scene and record.final.get(target.response):
                x, y, sources = rows[target.key]
                x.append(record.values(names))
                y.append(record.responses[target.response].value)
                sources.append(f"{record.study}/{record.evaluation}")
    return DomainData(
        names,
        np.array([p.lower for p in study.free]),
        np.array([p.upper for p in study.free]),
        {
            key: ResponseData(key, np.array(x, float).reshape(-1, len(names)), np.array(y), s)
            for key, (x, y, s) in rows.items()
        },
        digest(sorted(record.key for record in records)),
    )


def unit_box(x: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """SI inputs (rows) in the unit box of the domain [lower, upper], where the models live."""
    unit: np.ndarray = (np.atleast_2d(x) - lower) / (upper - lower)
    return unit


class Model(Protocol):
    """A fitted global model of one response, on the domain's unit box."""

    def predict(self, x_unit: np.ndarray) -> np.ndarray: ...

    def predict_std(self, x_unit: np.ndarray) -> np.ndarray: ...

    @property
    def noise_sd(self) -> float: ...

    def describe(self) -> str: ...


@dataclass
class KrigingModel:
    """The optimizer's per-response Kriging (demcal.optimizer.surrogates.kriging)."""

    model: Any

    @classmethod
    def fit(
        cls, x_unit: np.ndarray, y: np.ndarray, names: list[str], seed: int, key: str
    ) -> KrigingModel:
        from demcal.optimizer.surrogates.kriging import KrigingSurrogate

        return cls(KrigingSurrogate(restarts=KRIGING_RESTARTS, seed=seed).fit(x_unit, y))

    def predict(self, x_unit: np.ndarray) -> np.ndarray:
        return np.asarray(self.model.predict(np.atleast_2d(x_unit)), float)

    def predict_std(self, x_unit: np.ndarray) -> np.ndarray:
        """The Kriging posterior's sd of the noise-free response."""
        return np.asarray(self.model.predict_std(np.atleast_2d(x_unit)), float)

    @property
    def noise_sd(self) -> float:
        """The scatter of single simulations the fit found (its nugget)."""
        return float(self.model.noise_sd)

    def describe(self) -> str:
        return f"Kriging (Matérn 5/2, linear trend), noise sd {self.model.noise_sd:.3g}"


def _protected_exp(x: np.ndarray) -> np.ndarray:
    """exp, capped so that an evolved program never overflows (gplearn protects its own
    functions the same way)."""
    values: np.ndarray = np.exp(np.clip(x, -50.0, 50.0))
    return values


@dataclass
class SymbolicModel:
    """Symbolic regression (gplearn) on the unit box and the standardised response.

    Genetic programming gives no posterior: its training RMSE, which holds the simulations'
    scatter and the equation's own error alike, counts as the scatter of a simulation about
    it (``noise_sd``), so that it widens each target's band, and its sd is 0."""

    program: Any
    mean: float
    sd: float
    key: str
    rmse: float

    @classmethod
    def fit(
        cls, x_unit: np.ndarray, y: np.ndarray, names: list[str], seed: int, key: str
    ) -> SymbolicModel:
        from gplearn.functions import make_function
        from gplearn.genetic import SymbolicRegressor

        functions = (
            "add",
            "sub",
            "mul",
            "div",
            "sqrt",
            "log",
            make_function(function=_protected_exp, name="exp", arity=1),
            make_function(function=np.tanh, name="tanh", arity=1),
        )
        mean, sd = float(np.mean(y)), float(np.std(y)) or 1.0
        regressor = SymbolicRegressor(
            population_size=POPULATION,
            generations=GENERATIONS,
            function_set=functions,
            parsimony_coefficient=PARSIMONY,
            feature_names=[f"x_{name}" for name in names],
            random_state=seed,
            n_jobs=1,
        )
        regressor.fit(x_unit, (y - mean) / sd)
        fitted = mean + sd * np.asarray(regressor.predict(x_unit))
        return cls(regressor, mean, sd, key, float(np.sqrt(np.mean((y - fitted) ** 2))))

    def predict(self, x_unit: np.ndarray) -> np.ndarray:
        return self.mean + self.sd * np.asarray(self.program.predict(np.atleast_2d(x_unit)))

    def predict_std(self, x_unit: np.ndarray) -> np.ndarray:
        return np.zeros(len(np.atleast_2d(x_unit)))

    @property
    def noise_sd(self) -> float:
        return self.rmse

    def describe(self) -> str:
        return f"{self.key} = {self.mean:.6g} + {self.sd:.6g} * {self.program._program}"


#: How each kind of model is fitted: (x in the unit box, y, input names, seed, response key).
FITTERS: dict[str, Callable[[np.ndarray, np.ndarray, list[str], int, str], Model]] = {
    "kriging": KrigingModel.fit,
    "symbolic": SymbolicModel.fit,
}


@dataclass
class Metamodels:
    """The fitted models of a domain, each response's by kind, and what they were fitted on."""

    names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    models: dict[str, dict[str, Model]]
    training_size: dict[str, int]
    fingerprint: str
    exclude: tuple[str, ...] = ()
    #: what these models hold (:data:`FORMAT` when built); models of an older one are rebuilt
    format: int = 1

    def unit(self, x: np.ndarray) -> np.ndarray:
        """SI inputs (rows) in the domain's unit box, where the models live."""
        return unit_box(x, self.lower, self.upper)

    def predict(self, key: str, kind: str, x: np.ndarray) -> np.ndarray:
        """The model's prediction at SI inputs ``x`` (rows)."""
        return self.models[key][kind].predict(self.unit(x))


def build(
    data: DomainData, kinds: tuple[str, ...], seed: int, exclude: tuple[str, ...]
) -> Metamodels:
    """One model of each kind per response of ``data``."""
    unknown = [k for k in kinds if k not in MODEL_KINDS]
    if unknown:
        raise ConfigError(f"--model {unknown[0]}: use one of {', '.join(MODEL_KINDS)}")
    models: dict[str, dict[str, Model]] = {}
    sizes = {}
    for key, rows in data.responses.items():
        if len(rows.y) < len(data.names) + 2:
            raise ConfigError(
                f"{key}: {len(rows.y)} simulations in the archive for {len(data.names)} inputs; "
                f"a global model needs many more: run demcal sample first"
            )
        unit = unit_box(rows.x, data.lower, data.upper)
        models[key] = {}
        for kind in kinds:
            models[key][kind] = FITTERS[kind](unit, rows.y, data.names, seed, key)
        sizes[key] = len(rows.y)
    return Metamodels(
        data.names, data.lower, data.upper, models, sizes, data.fingerprint, exclude, FORMAT
    )


@dataclass(frozen=True)
class Validation:
    """How a model predicts held-out simulations: R², RMSE, the largest errors."""

    key: str
    kind: str
    count: int
    r2: float
    rmse: float
    residuals: np.ndarray
    worst: list[tuple[str, float, float]]


def validate(models: Metamodels, held_out: DomainData, worst: int = 5) -> list[Validation]:
    """Each model against the held-out simulations of its response."""
    results = []
    for key, by_kind in models.models.items():
        rows = held_out.responses.get(key)
        if rows is None or len(rows.y) < 2:
            continue
        for kind in by_kind:
            predicted = models.predict(key, kind, rows.x)
            residuals = rows.y - predicted
            total = float(np.sum((rows.y - rows.y.mean()) ** 2))
            order = np.argsort(-np.abs(residuals))[:worst]
            results.append(
                Validation(
                    key,
                    kind,
                    len(rows.y),
                    1.0 - float(np.sum(residuals**2)) / total if total > 0 else math.nan,
                    float(np.sqrt(np.mean(residuals**2))),
                    residuals,
                    [(rows.sources[i], float(rows.y[i]), float(predicted[i])) for i in order],
                )
            )
    return results


def models_file(study: Study) -> Path:
    return study.files.dir / "metamodels" / "models.pkl"


def save(study: Study, models: Metamodels) -> Path:
    path = models_file(study)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    temporary.write_bytes(pickle.dumps(models))
    temporary.replace(path)
    return path


def load(study: Study) -> Metamodels:
    path = models_file(study)
    if not path.is_file():
        raise ConfigError(f"{path}: no metamodels yet; run demcal metamodel build first")
    try:
        models = pickle.loads(path.read_bytes())
    except (pickle.UnpicklingError, AttributeError, EOFError, ImportError) as exc:
        raise ConfigError(f"{path}: unreadable ({exc}); run demcal metamodel build again") from None
    if not isinstance(models, Metamodels):
        raise ConfigError(f"{path}: not demcal's metamodels; run demcal metamodel build again")
    if models.format != FORMAT:
        raise ConfigError(
            f"{path}: built by an earlier demcal, without the models' uncertainty; run demcal "
            "metamodel build again"
        )
    return models


@dataclass(frozen=True)
class Optimum:
    """A local optimum of the objective on the metamodels: free values, objective, the
    predicted responses and the models' sd of them, and how many starts ended there."""

    values: dict[str, float]
    objective: float
    predicted: dict[str, float]
    predicted_sd: dict[str, float]
    starts: int


@dataclass(frozen=True)
class MetamodelCalibration:
    """A material calibrated on a domain's metamodels (Richter & Will 2021, sec. 4): every
    distinct optimum, best first, the inputs held at the material's values, and the solution
    set of the material's free box on those models with a verdict per free parameter
    (:mod:`demcal.analysis.solutions`)."""

    optima: list[Optimum]
    held: dict[str, float]
    analysis: SolutionAnalysis


@dataclass(frozen=True)
class MaterialResponse:
    """One global model seen from a material's free box: points in the unit box of the
    material's free parameters, mapped to the domain's inputs by ``inputs`` (held ones at the
    material's values). Mean, sd and noise, as the solution-space analysis reads a model."""

    models: Metamodels
    key: str
    kind: str
    inputs: Callable[[np.ndarray], np.ndarray]

    @property
    def model(self) -> Model:
        return self.models.models[self.key][self.kind]

    def predict(self, x: np.ndarray) -> np.ndarray:
        return self.model.predict(self.models.unit(self.inputs(x)))

    def predict_std(self, x: np.ndarray) -> np.ndarray:
        return self.model.predict_std(self.models.unit(self.inputs(x)))

    @property
    def noise_sd(self) -> float:
        return self.model.noise_sd


def material_inputs(domain: Study, material: Study) -> tuple[list[str], dict[str, float]]:
    """The domain's inputs the material frees, and the value it holds each other one at (a
    fixed parameter or a scene setting such as the d50 of ``demcal psd fit``).

    Refused, naming the field: a material of another scene or engine, a free parameter that
    is not an input of the models, a held value or bound outside the domain, and a setting,
    fixed parameter or time-step fraction of the domain the material gives another value (the
    models know only one)."""
    if set(material.scenes) != set(domain.scenes) or material.engine.name != domain.engine.name:
        raise ConfigError(
            f"the material's scenes {', '.join(material.scenes)} on {material.engine.name} are "
            f"not the domain's ({', '.join(domain.scenes)} on {domain.engine.name})"
        )
    bounds = {p.name: (p.lower, p.upper) for p in domain.free}
    free = []
    for p in material.free:
        if p.name not in bounds:
            raise ConfigError(
                f"parameters.{p.name}: not an input of the domain's models "
                f"({', '.join(bounds)}); fix it at the domain's value"
            )
        lower, upper = bounds[p.name]
        if p.lower < lower or p.upper > upper:
            raise ConfigError(
                f"parameters.{p.name}: [{p.lower:g}, {p.upper:g}] leaves the domain "
                f"[{lower:g}, {upper:g}]; the models would extrapolate"
            )
        free.append(p.name)
    scene = next(iter(domain.scenes))
    domain_settings, domain_fixed, _ = domain.archive_view(scene)
    settings, fixed, _ = material.archive_view(scene)
    for name, value in domain_settings.items():
        if settings.get(name) != value:
            raise ConfigError(
                f"scenes.{scene}.settings.{name}: the domain's models were trained at {value}, "
                f"the material gives {settings.get(name)}; they do not know another value"
            )
    if material.timestep_fraction != domain.timestep_fraction:
        raise ConfigError(
            f"timestep_fraction: the domain's models were trained at {domain.timestep_fraction:g}, "
            f"the material gives {material.timestep_fraction:g}"
        )
    held = {}
    for name, (lower, upper) in bounds.items():
        if name in free:
            continue
        value = fixed.get(name)
        where = f"scenes.{scene}.settings" if name in material.settings[scene] else "fixed"
        if value is None or not lower <= value <= upper:
            raise ConfigError(
                f"{where}.{name}: {value} is outside the domain [{lower:g}, {upper:g}] of the "
                f"models; give a value inside it or make it free"
            )
        held[name] = float(value)
    for name, value in domain_fixed.items():
        if name not in bounds and fixed.get(name) != value:
            where = f"scenes.{scene}.settings" if name in material.settings[scene] else "fixed"
            raise ConfigError(
                f"{where}.{name}: the domain's models were trained at {value:g}, the material "
                f"gives {fixed.get(name)}; they do not know another value"
            )
    return free, held


def calibrate(
    models: Metamodels,
    kind: str,
    material: Study,
    free: list[str],
    held: dict[str, float],
    starts: int,
    explore_command: str,
    seed: int = 1,
    samples: int = 2**16,
) -> MetamodelCalibration:
    """L-BFGS-B on the material's objective of the predicted responses, from ``starts``
    Sobol points of its free box (optima closer than 0.02 of the box are one); then the
    solution set of the box on the same models (``samples`` points; ``explore_command``:
    how to add simulations where the models cannot decide)."""
    from scipy.optimize import minimize

    from demcal.analysis.solution_report import analyse_predictor
    from demcal.optimizer.designs import sobol_sequence
    from demcal.optimizer.responses import ResponsePredictor

    objective = material.objective
    specs = {p.name: p for p in material.free}
    low = np.array([specs[n].lower for n in free])
    high = np.array([specs[n].upper for n in free])

    def inputs(unit: np.ndarray) -> np.ndarray:
        unit = np.atleast_2d(unit)
        values = {n: low[i] + unit[:, i] * (high[i] - low[i]) for i, n in enumerate(free)}
        values |= {n: np.full(len(unit), v) for n, v in held.items()}
        return np.column_stack([values[n] for n in models.names])

    view = {key: MaterialResponse(models, key, kind, inputs) for key in objective.keys}
    predictor = ResponsePredictor(view, objective)

    def predicted(unit: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
        means, stds = predictor.predict(unit)
        return {k: float(v[0]) for k, v in means.items()}, {k: float(v[0]) for k, v in stds.items()}

    rng = np.random.default_rng(seed)
    ends = []
    for start in sobol_sequence(starts, len(free), rng):
        result = minimize(
            lambda unit: float(predictor.objective_mean(unit)[0]),
            start,
            method="L-BFGS-B",
            bounds=[(0.0, 1.0)] * len(free),
        )
        ends.append((float(result.fun), np.clip(result.x, 0.0, 1.0)))
    ends.sort(key=lambda end: end[0])
    optima: list[tuple[np.ndarray, float, int]] = []
    for fun, unit in ends:
        for i, (kept, kept_fun, count) in enumerate(optima):
            if np.linalg.norm(unit - kept) < 0.02 * math.sqrt(len(free)):
                optima[i] = (kept, kept_fun, count + 1)
                break
        else:
            optima.append((unit, fun, 1))
    analysis = analyse_predictor(
        predictor,
        {key: model.noise_sd for key, model in view.items()},
        free,
        [specs[n].spec.unit for n in free],
        low,
        high,
        explore_command,
        samples=samples,
        seed=seed,
    )
    return MetamodelCalibration(
        [
            Optimum(
                {n: float(low[i] + unit[i] * (high[i] - low[i])) for i, n in enumerate(free)},
                fun,
                *predicted(unit),
                count,
            )
            for unit, fun, count in optima
        ],
        held,
        analysis,
    )
