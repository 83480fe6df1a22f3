"""The strategies by name: the one list that the settings validate and the optimizer dispatches on.

Light on purpose (no NumPy, SciPy or SMT): :class:`~.settings.OptimizerSettings`
imports it to check ``optimizer.strategy``, and the classes are imported
only when the optimizer first needs one. Each entry also says which
surrogate a strategy uses when the settings leave ``surrogate`` unset, and
which surrogates it can work with at all.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class StrategyEntry:
    """A registered strategy.

    ``strategy``: the :class:`~.search.Strategy` subclass, or ``"module:Class"``
    to import on first use; ``surrogate``: the default surrogate;
    ``surrogates``: the surrogates it can work with (None: any);
    ``samples_per_parameter``: the initial design's size per free parameter
    when the settings leave ``initial_size`` unset (None: 2d + 1 plus one
    per worker); ``stops_early``: whether early termination may stop its
    evaluations (a finite-difference step must finish); ``step_size``:
    whether it moves by the DYCORS step size, whose collapse is a stop reason.
    """

    strategy: type | str
    surrogate: str = "cubic_rbf"
    surrogates: tuple[str, ...] | None = None
    samples_per_parameter: int | None = None
    stops_early: bool = True
    step_size: bool = True


STRATEGIES: dict[str, StrategyEntry] = {
    "dycors": StrategyEntry("demcal.optimizer.search:Dycors", "cubic_rbf"),
    "kriging_ei": StrategyEntry("demcal.optimizer.search:KrigingEI", "kriging", ("kriging",)),
    "response_ei": StrategyEntry("demcal.optimizer.search:ResponseEI", "cubic_rbf"),
    "rackl_hanley": StrategyEntry(
        "demcal.optimizer.rackl_hanley:RacklHanley",
        "cubic_rbf",
        samples_per_parameter=3,
        stops_early=False,
        step_size=False,
    ),
}
#: Strategies that work on per-response models and so need the targets (the objective).
RESPONSE_STRATEGIES = ("response_ei", "rackl_hanley")


def register_strategy(
    name: str,
    strategy: type | str,
    surrogate: str = "cubic_rbf",
    surrogates: tuple[str, ...] | None = None,
) -> None:
    """Make ``strategy`` available as ``optimizer.strategy: name`` (see :class:`StrategyEntry`)."""
    if name in STRATEGIES:
        raise ValueError(f"strategy {name!r} is already registered")
    STRATEGIES[name] = StrategyEntry(strategy, surrogate, surrogates)


def strategy_class(name: str) -> type:
    """The class registered as ``name``, imported on first use."""
    strategy = STRATEGIES[name].strategy
    if isinstance(strategy, str):
        module, _, attribute = strategy.partition(":")
        strategy = getattr(importlib.import_module(module), attribute)
    return strategy
