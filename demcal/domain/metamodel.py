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
  ``response = mean + sd * f(x_name, ...)`` with ``x_name`` the parameter scaled to [0, 1];
- ``multi_fidelity``: multi-fidelity Kriging (demcal.optimizer.surrogates.multi_fidelity) of
  the fine runs and the archive's runs of the same domain at a cheaper level of the study
  (``--fidelity``): a large coarse campaign and a small fine one (docs/fidelity.md).

The models are saved under ``results/<study>/metamodels/`` with the fingerprint of the data
they were trained on, so a later command knows when the archive has moved on.
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from demcal.archive.reuse import compatible_simulations
from demcal.archive.simulation import digest
from demcal.archive.store import Archive
from demcal.errors import ConfigError
from demcal.optimizer.bounds import to_unit_box
from demcal.optimizer.surrogates.multi_fidelity import LevelData, MultiFidelityKriging
from demcal.results.records import FINE
from demcal.study.model import Study

MODEL_KINDS = ("kriging", "symbolic", "multi_fidelity")
#: The kinds built when none is named: those that need no cheaper level's runs.
SINGLE_LEVEL_KINDS = ("kriging", "symbolic")
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
    fidelity: str = FINE,
) -> DomainData:
    """The study's domain and its compatible simulations at level ``fidelity`` (as for reuse:
    :func:`demcal.archive.reuse.compatible_simulations`): without those of the studies
    ``exclude`` names (a held-out validation campaign), or those of the studies ``only``
    names alone. A damaged simulation is left out, or gives only its sound responses, as the
    archive reads it (:meth:`Archive.warn_damaged` names them)."""
    names = [p.name for p in study.free]
    rows: dict[str, tuple[list[list[float]], list[float], list[str]]] = {
        t.key: ([], [], []) for t in study.targets
    }
    records = compatible_simulations(
        study,
        archive,
        lambda name: name not in exclude and (only is None or name in only),
        fidelity,
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


class Model(Protocol):
    """A fitted global model of one response, on the domain's unit box."""

    def predict(self, x_unit: np.ndarray) -> np.ndarray: ...

    def predict_std(self, x_unit: np.ndarray) -> np.ndarray: ...

    @property
    def noise_sd(self) -> float: ...

    @property
    def discrepancy_sd(self) -> float:
        """The model's own error about the simulator that no posterior holds: a discrepancy
        that widens each target's band (docs/solutions.md)."""
        ...

    def describe(self) -> str: ...


@dataclass
class KrigingMetamodel:
    """The optimizer's per-response Kriging (demcal.optimizer.surrogates.kriging)."""

    model: Any

    @classmethod
    def fit(
        cls, x_unit: np.ndarray, y: np.ndarray, names: list[str], seed: int, key: str
    ) -> KrigingMetamodel:
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

    @property
    def discrepancy_sd(self) -> float:
        """None beyond its posterior sd."""
        return 0.0

    def describe(self) -> str:
        return f"Kriging (Matérn 5/2, linear trend), noise sd {self.model.noise_sd:.3g}"


def _protected_exp(x: np.ndarray) -> np.ndarray:
    """exp, capped so that an evolved program never overflows (gplearn protects its own
    functions the same way)."""
    values: np.ndarray = np.exp(np.clip(x, -50.0, 50.0))
    return values


@dataclass
class SymbolicMetamodel:
    """Symbolic regression (gplearn) on the unit box and the standardised response.

    Genetic programming gives no posterior: its sd is 0, and its training RMSE, which holds
    the simulations' scatter and the equation's own error alike, counts as its discrepancy
    from the simulator (``discrepancy_sd``), so that it widens each target's band; it makes
    no separate estimate of the simulations' scatter (``noise_sd`` 0)."""

    program: Any
    mean: float
    sd: float
    key: str
    rmse: float

    @classmethod
    def fit(
        cls, x_unit: np.ndarray, y: np.ndarray, names: list[str], seed: int, key: str
    ) -> SymbolicMetamodel:
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
        return 0.0

    @property
    def discrepancy_sd(self) -> float:
        return self.rmse

    def describe(self) -> str:
        return f"{self.key} = {self.mean:.6g} + {self.sd:.6g} * {self.program._program}"


@dataclass
class MultiFidelityMetamodel:
    """Multi-fidelity Kriging of the fine runs and a cheaper level's (the fine prediction)."""

    model: MultiFidelityKriging
    level: str

    @classmethod
    def fit(
        cls, fine: tuple[np.ndarray, np.ndarray], cheap: tuple[np.ndarray, np.ndarray], level: str
    ) -> MultiFidelityMetamodel:
        """From the fine and the cheaper level's (x in the unit box, y)."""
        model = MultiFidelityKriging(restarts=KRIGING_RESTARTS).fit(
            [
                LevelData(cheap[0], cheap[1], np.zeros(len(cheap[1]))),
                LevelData(fine[0], fine[1], np.zeros(len(fine[1]))),
            ]
        )
        return cls(model, level)

    def predict(self, x_unit: np.ndarray) -> np.ndarray:
        return self.model.predict(x_unit)

    def predict_std(self, x_unit: np.ndarray) -> np.ndarray:
        return self.model.predict_std(x_unit)

    @property
    def noise_sd(self) -> float:
        return self.model.noise_sd

    @property
    def discrepancy_sd(self) -> float:
        return 0.0

    def describe(self) -> str:
        return (
            f"multi-fidelity Kriging ({self.level} -> fine, scale {self.model.rho:.3g}), "
            f"noise sd {self.model.noise_sd:.3g}"
        )


#: How each single-level kind of model is fitted: (x in the unit box, y, input names, seed,
#: response key).
FITTERS: dict[str, Callable[[np.ndarray, np.ndarray, list[str], int, str], Model]] = {
    "kriging": KrigingMetamodel.fit,
    "symbolic": SymbolicMetamodel.fit,
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
        return to_unit_box(np.atleast_2d(x), self.lower, self.upper)

    def predict(self, key: str, kind: str, x: np.ndarray) -> np.ndarray:
        """The model's prediction at SI inputs ``x`` (rows)."""
        return self.models[key][kind].predict(self.unit(x))


def build(
    data: DomainData,
    kinds: tuple[str, ...],
    seed: int,
    exclude: tuple[str, ...],
    cheap: tuple[str, DomainData] | None = None,
) -> Metamodels:
    """One model of each kind per response of ``data``; ``cheap``: a cheaper level's name and
    its data, which the ``multi_fidelity`` kind needs."""
    unknown = [k for k in kinds if k not in MODEL_KINDS]
    if unknown:
        raise ConfigError(f"--model {unknown[0]}: use one of {', '.join(MODEL_KINDS)}")
    if "multi_fidelity" in kinds and cheap is None:
        raise ConfigError(
            "--model multi_fidelity: name the cheaper level whose runs it learns from "
            "(--fidelity LEVEL; demcal sample --fidelity LEVEL runs them)"
        )
    models: dict[str, dict[str, Model]] = {}
    sizes = {}
    for key, rows in data.responses.items():
        if len(rows.y) < len(data.names) + 2:
            raise ConfigError(
                f"{key}: {len(rows.y)} simulations in the archive for {len(data.names)} inputs; "
                f"a global model needs many more: run demcal sample first"
            )
        unit = to_unit_box(np.atleast_2d(rows.x), data.lower, data.upper)
        models[key] = {
            kind: FITTERS[kind](unit, rows.y, data.names, seed, key)
            for kind in kinds
            if kind in FITTERS
        }
        if cheap is not None and "multi_fidelity" in kinds:
            level, cheap_data = cheap
            low = cheap_data.responses[key]
            if len(low.y) < len(data.names) + 2:
                raise ConfigError(
                    f"{key}: {len(low.y)} simulations at {level} in the archive for "
                    f"{len(data.names)} inputs; run demcal sample --fidelity {level} first"
                )
            low_unit = to_unit_box(np.atleast_2d(low.x), data.lower, data.upper)
            models[key]["multi_fidelity"] = MultiFidelityMetamodel.fit(
                (unit, rows.y), (low_unit, low.y), level
            )
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


def save(study: Study, models: Metamodels) -> Path:
    path = study.files.metamodels
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".tmp")
    temporary.write_bytes(pickle.dumps(models))
    temporary.replace(path)
    return path


#: Where the classes of models built before demcal's third architecture step (3b35631) live now.
MOVED_CLASSES = {
    ("demcal.metamodel", "Metamodels"): (__name__, "Metamodels"),
    ("demcal.metamodel", "KrigingModel"): (__name__, "KrigingMetamodel"),
    ("demcal.metamodel", "SymbolicModel"): (__name__, "SymbolicMetamodel"),
}


class _Unpickler(pickle.Unpickler):
    """Reads saved models, those of an earlier layout of the code too (`MOVED_CLASSES`)."""

    def find_class(self, module: str, name: str) -> Any:
        module, name = MOVED_CLASSES.get((module, name), (module, name))
        return super().find_class(module, name)


def load(study: Study) -> Metamodels:
    path = study.files.metamodels
    if not path.is_file():
        raise ConfigError(f"{path}: no metamodels yet; run demcal metamodel build first")
    try:
        with open(path, "rb") as handle:
            models = _Unpickler(handle).load()
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
