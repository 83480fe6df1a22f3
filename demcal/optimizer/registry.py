"""The optimizer's plug-ins by name: strategies, surrogates, response models, initial designs.

The one list of each that the settings validate and the optimizer loads
from (:class:`~demcal.plugins.Registry`). Light on purpose (no NumPy, SciPy
or SMT): :class:`~.settings.OptimizerSettings` imports it to check names,
and a plug-in's module is imported only when the optimizer first uses it.

* :data:`STRATEGIES` — :class:`~.strategies.base.Strategy` subclasses, with
  what the optimizer must know of each (:class:`StrategyEntry`);
* :data:`SURROGATES` — models of the objective,
  :class:`~.surrogates.base.Surrogate` subclasses;
* :data:`RESPONSE_MODELS` — models of one response each,
  :class:`~.surrogates.base.ResponseModel` subclasses;
* :data:`DESIGNS` — initial designs, functions
  ``(size, dimension, rng) -> array`` of points in the unit box
  (:class:`DesignEntry`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from demcal.plugins import Entry, Registry

if TYPE_CHECKING:
    from .strategies.base import Strategy


@dataclass(frozen=True)
class StrategyEntry(Entry):
    """A registered strategy (``target``: the class or ``"module:Class"``).

    ``surrogate``: the default surrogate; ``surrogates``: the surrogates it
    can work with (None: any); ``samples_per_parameter``: the initial
    design's size per free parameter when the settings leave
    ``initial_size`` unset (None: 2d + 1 plus one per worker);
    ``stops_early``: whether early termination may stop its evaluations (a
    finite-difference step must finish); ``step_size``: whether it moves by
    the DYCORS step size, whose collapse is a stop reason;
    ``needs_targets``: whether it works on the per-response models and so
    needs the targets (the optimizer's objective).
    """

    surrogate: str = "cubic_rbf"
    surrogates: tuple[str, ...] | None = None
    samples_per_parameter: int | None = None
    stops_early: bool = True
    step_size: bool = True
    needs_targets: bool = False


@dataclass(frozen=True)
class DesignEntry(Entry):
    """A registered initial design; ``maximin``: keep the best of ``design_tries`` draws."""

    maximin: bool = True


_STRATEGIES = "demcal.optimizer.strategies"
_SURROGATES = "demcal.optimizer.surrogates"

STRATEGIES: Registry[StrategyEntry] = Registry(
    "strategy",
    {
        "dycors": StrategyEntry(f"{_STRATEGIES}.dycors:Dycors"),
        "kriging_ei": StrategyEntry(
            f"{_STRATEGIES}.kriging_ei:KrigingEI", surrogate="kriging", surrogates=("kriging",)
        ),
        "response_ei": StrategyEntry(f"{_STRATEGIES}.response_ei:ResponseEI", needs_targets=True),
        "solution_map": StrategyEntry(
            f"{_STRATEGIES}.solution_map:SolutionMap", needs_targets=True
        ),
        "rackl_hanley": StrategyEntry(
            f"{_STRATEGIES}.rackl_hanley:RacklHanley",
            samples_per_parameter=3,
            stops_early=False,
            step_size=False,
            needs_targets=True,
        ),
    },
)

SURROGATES: Registry[Entry] = Registry(
    "surrogate",
    {
        "cubic_rbf": Entry(f"{_SURROGATES}.cubic_rbf:CubicRBF"),
        "kriging": Entry(f"{_SURROGATES}.kriging:KrigingSurrogate"),
        "smt_rbf": Entry(f"{_SURROGATES}.smt_rbf:SMTRadialBasis"),
    },
)

RESPONSE_MODELS: Registry[Entry] = Registry(
    "response model",
    {
        "kriging": Entry(f"{_SURROGATES}.kriging:KrigingSurrogate"),
        "cubic_rbf": Entry(f"{_SURROGATES}.cubic_rbf:ResponseRBF"),
    },
)

DESIGNS: Registry[DesignEntry] = Registry(
    "initial design",
    {
        "symmetric_latin_hypercube": DesignEntry(
            "demcal.optimizer.designs:symmetric_latin_hypercube"
        ),
        "latin_hypercube": DesignEntry("demcal.optimizer.designs:latin_hypercube"),
        "sobol": DesignEntry("demcal.optimizer.designs:sobol_sequence", maximin=False),
        "halton": DesignEntry("demcal.optimizer.designs:halton_sequence", maximin=False),
        "fssf_f": DesignEntry("demcal.optimizer.designs:fssf_f", maximin=False),
    },
)


def register_strategy(name: str, strategy: type | str, **metadata: Any) -> None:
    """Make ``strategy`` available as ``optimizer.strategy: name``.

    ``metadata``: the other fields of :class:`StrategyEntry` (``surrogate``,
    ``samples_per_parameter``, ``needs_targets``, ...).
    """
    STRATEGIES.register(name, StrategyEntry(strategy, **metadata))


def strategy_class(name: str) -> type[Strategy]:
    """The class registered as ``name``, imported on first use."""
    strategy: type[Strategy] = STRATEGIES.load(name)
    return strategy
