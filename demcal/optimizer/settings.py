"""Validated settings of the optimizer (the config section ``optimizer:``).

Defaults follow Samuelsson (2023), Table 4.2: t = 200 candidates,
sigma_max = 0.2, sigma_min = sigma_max / 2**6, 3 successes to double the
step, 4 failures to halve it, merit weights cycling 0.3/0.5/0.8/0.95 and
an early-termination factor pattern c = 10, 5, 2.5.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from demcal.errors import unknown_field

from .registry import DESIGNS, RESPONSE_MODELS, STRATEGIES, SURROGATES

#: The early-termination rules (``EarlyTerminationSettings.rule``).
RULES = ("weighed", "eq_3_4")


@dataclass(frozen=True)
class EarlyTerminationSettings:
    """Early termination after Samuelsson (2023), section 3.6.1, eq. 3.4.

    ``thresholds`` are the factors c applied in turn; ``progress_boundaries``
    are the fractions of the adaptive budget at which the next factor takes
    over (the thesis: c = 10 for the first half, 5 for the third quarter,
    2.5 for the rest). ``rule``: ``weighed`` also weighs the work a stop
    saves and the estimate's trend, and finishes a run once ``last_stretch``
    of it is done; ``eq_3_4`` is the thesis' rule alone
    (:mod:`.early_termination`).
    """

    enabled: bool = True
    thresholds: tuple[float, ...] = (10.0, 5.0, 2.5)
    progress_boundaries: tuple[float, ...] = (0.5, 0.75)
    rule: str = "weighed"
    last_stretch: float = 0.9


@dataclass(frozen=True)
class OptimizerSettings:
    """Everything that tunes the optimizer; build it with :meth:`from_dict`.

    Step sizes and distances are in the unit box (each parameter scaled to
    [0, 1]). ``strategy``, ``surrogate``, ``response_model`` and
    ``initial_design`` name entries of the registries in :mod:`.registry`.
    ``strategy`` defaults to dycors, which needs no targets: the default of
    the optimizer on its own. A study's default is its schema's
    (response_ei; dycors with a Rayleigh cost term), set by
    :func:`demcal.study.config.load_study`.
    ``initial_size`` None means 2d+1 plus one point per worker
    (Samuelsson 2023, section 3.7: q + P). ``surrogate`` None means the
    strategy's own (registered with it): cubic_rbf for dycors, kriging for
    kriging_ei.
    ``polish_candidate``: at the most exploitative weight, propose the
    local minimum of the surrogate within 2 sigma of the best point, and
    always so in the last ``final_exploitation`` share of the budget (both
    additions to the thesis, chosen from the benchmark).
    ``stop_on_step_collapse``: whether a step size driven below sigma_min
    is a stop reason (the step then stays at sigma_min either way).
    ``failure_tolerance`` None means max(4, d): the thesis' 4 for its 2-D
    case, growing with the dimension as in Regis & Shoemaker (2013).
    ``confirm_replicates``: once the search has stopped (before any mapping of
    the solution set), simulate the best point this many times more (new
    seeds) and report their mean; their scatter floors the response models'
    noise (0: no confirmation).
    ``stop_when_known``: end the search (``response_ei``) once the best
    point's predicted responses meet every target within its spread and the
    expected improvement has stayed below ``calm_share`` of the noise level
    for ``calm_proposals`` proposals in a row.
    ``map_solutions``: once the search for the best point has stopped, this
    many more evaluations map the set of parameters that meet the targets as
    well (the ``solution_map`` strategy; needs the targets; 0: none).
    ``fidelity``: a cheaper fidelity level the search may also spend
    (:mod:`.levels`: multi-fidelity response models, the level of each run chosen by its
    worth per CPU second); None: fine runs only.
    """

    strategy: str = "dycors"
    surrogate: str | None = None
    initial_design: str = "symmetric_latin_hypercube"
    initial_size: int | None = None
    design_tries: int = 50
    max_evaluations: int = 100
    max_seconds: float | None = None
    target_objective: float | None = None
    no_improvement_evaluations: int | None = None
    stop_on_step_collapse: bool = True
    candidates: int = 200
    sigma_max: float = 0.2
    sigma_min: float = 0.2 / 2**6
    success_tolerance: int = 3
    failure_tolerance: int | None = None
    weights: tuple[float, ...] = (0.3, 0.5, 0.8, 0.95)
    polish_candidate: bool = True
    final_exploitation: float = 0.1
    min_distance: float = 1e-5
    failed_exclusion_radius: float = 0.02
    duplicate_tolerance: float = 1e-7
    kriging_restarts: int = 3
    response_model: str = "kriging"
    confirm_replicates: int = 0
    stop_when_known: bool = True
    calm_share: float = 0.05
    calm_proposals: int = 3
    map_solutions: int = 0
    fidelity: str | None = None
    early_termination: EarlyTerminationSettings = field(default_factory=EarlyTerminationSettings)

    @classmethod
    def from_dict(cls, values: dict[str, Any] | None) -> OptimizerSettings:
        """Build settings from a plain mapping, rejecting unknown keys."""
        values = dict(values or {})
        known = {f.name for f in dataclasses.fields(cls)}
        for key in values:
            if key not in known:
                raise ValueError(unknown_field(f"optimizer.{key}", known))
        if "weights" in values:
            values["weights"] = tuple(_as_list("weights", values["weights"]))
        if "early_termination" in values:
            values["early_termination"] = _early_termination_from(values["early_termination"])
        settings = cls(**values)
        settings.validate()
        return settings

    @property
    def surrogate_name(self) -> str:
        """The surrogate in use (resolves the None default per strategy)."""
        if self.surrogate is not None:
            return self.surrogate
        return STRATEGIES[self.strategy].surrogate

    def failures_to_halve(self, dimension: int) -> int:
        """Consecutive failures that halve the step size."""
        return self.failure_tolerance or max(4, dimension)

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-able mapping that :meth:`from_dict` accepts back."""
        result = dataclasses.asdict(self)
        result["weights"] = list(self.weights)
        result["early_termination"] = {
            "enabled": self.early_termination.enabled,
            "thresholds": list(self.early_termination.thresholds),
            "progress_boundaries": list(self.early_termination.progress_boundaries),
            "rule": self.early_termination.rule,
            "last_stretch": self.early_termination.last_stretch,
        }
        return result

    def validate(self) -> None:
        """Raise ValueError naming the key, the value and what is allowed."""
        _choice("strategy", self.strategy, tuple(STRATEGIES))
        if self.surrogate is not None:
            _choice("surrogate", self.surrogate, tuple(SURROGATES))
            usable = STRATEGIES[self.strategy].surrogates
            if usable is not None and self.surrogate not in usable:
                raise ValueError(
                    f"optimizer.surrogate: {self.surrogate!r} cannot serve strategy "
                    f"{self.strategy}; "
                    f"it needs {' or '.join(usable)} (or leave surrogate unset)"
                )
        _choice("initial_design", self.initial_design, tuple(DESIGNS))
        _choice("response_model", self.response_model, tuple(RESPONSE_MODELS))
        if self.initial_size is not None:
            _integer("initial_size", self.initial_size, 2, None)
        _integer("design_tries", self.design_tries, 1, None)
        _integer("max_evaluations", self.max_evaluations, 1, None)
        _number("max_seconds", self.max_seconds, 0.0, None, optional=True, open_low=True)
        _number("target_objective", self.target_objective, None, None, optional=True)
        if self.no_improvement_evaluations is not None:
            _integer("no_improvement_evaluations", self.no_improvement_evaluations, 1, None)
        _boolean("stop_on_step_collapse", self.stop_on_step_collapse)
        _integer("candidates", self.candidates, 1, None)
        _number("sigma_max", self.sigma_max, 0.0, 1.0, open_low=True)
        _number("sigma_min", self.sigma_min, 0.0, self.sigma_max, open_low=True)
        _integer("success_tolerance", self.success_tolerance, 1, None)
        if self.failure_tolerance is not None:
            _integer("failure_tolerance", self.failure_tolerance, 1, None)
        if not self.weights:
            raise ValueError("optimizer.weights: [] must hold at least one weight in [0, 1]")
        for weight in self.weights:
            _number("weights", weight, 0.0, 1.0)
        _boolean("polish_candidate", self.polish_candidate)
        _number("final_exploitation", self.final_exploitation, 0.0, 1.0)
        _number("min_distance", self.min_distance, 0.0, 1.0)
        _number("failed_exclusion_radius", self.failed_exclusion_radius, 0.0, 1.0)
        _number("duplicate_tolerance", self.duplicate_tolerance, 0.0, 1.0)
        _integer("kriging_restarts", self.kriging_restarts, 1, None)
        _integer("confirm_replicates", self.confirm_replicates, 0, 100)
        _integer("map_solutions", self.map_solutions, 0, None)
        if self.fidelity is not None and not isinstance(self.fidelity, str):
            raise ValueError(f"optimizer.fidelity: {self.fidelity!r} is not a level's name")
        _boolean("stop_when_known", self.stop_when_known)
        _integer("calm_proposals", self.calm_proposals, 1, None)
        _number("calm_share", self.calm_share, 0.0, 1.0, open_low=True)
        et = self.early_termination
        _boolean("early_termination.enabled", et.enabled)
        _choice("early_termination.rule", et.rule, RULES)
        _number("early_termination.last_stretch", et.last_stretch, 0.0, 1.0, open_low=True)
        if len(et.thresholds) != len(et.progress_boundaries) + 1:
            raise ValueError(
                f"optimizer.early_termination.progress_boundaries: {list(et.progress_boundaries)} "
                f"must hold one value fewer than thresholds ({len(et.thresholds)})"
            )
        for factor in et.thresholds:
            _number("early_termination.thresholds", factor, 0.0, None, open_low=True)
        previous = 0.0
        for boundary in et.progress_boundaries:
            _number("early_termination.progress_boundaries", boundary, previous, 1.0, open_low=True)
            previous = boundary


def _early_termination_from(values: Any) -> EarlyTerminationSettings:
    if isinstance(values, EarlyTerminationSettings):
        return values
    if not isinstance(values, dict):
        raise ValueError(f"optimizer.early_termination: {values!r} is not a mapping")
    known = {f.name for f in dataclasses.fields(EarlyTerminationSettings)}
    for key in values:
        if key not in known:
            raise ValueError(unknown_field(f"optimizer.early_termination.{key}", known))
    converted = dict(values)
    for key in ("thresholds", "progress_boundaries"):
        if key in converted:
            converted[key] = tuple(_as_list(f"early_termination.{key}", converted[key]))
    return EarlyTerminationSettings(**converted)


def _as_list(key: str, value: Any) -> list[Any]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"optimizer.{key}: {value!r} is not a list")
    return list(value)


def _choice(key: str, value: Any, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValueError(f"optimizer.{key}: {value!r} is not one of {', '.join(allowed)}")


def _boolean(key: str, value: Any) -> None:
    if not isinstance(value, bool):
        raise ValueError(f"optimizer.{key}: {value!r} is not true or false")


def _integer(key: str, value: Any, low: int, high: int | None) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"optimizer.{key}: {value!r} is not an integer")
    if value < low or (high is not None and value > high):
        upper = "" if high is None else f" and at most {high}"
        raise ValueError(
            f"optimizer.{key}: {value!r} is out of range; it must be at least {low}{upper}"
        )


def _number(
    key: str,
    value: Any,
    low: float | None,
    high: float | None,
    optional: bool = False,
    open_low: bool = False,
) -> None:
    if value is None and optional:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"optimizer.{key}: {value!r} is not a finite number")
    too_low = low is not None and (value <= low if open_low else value < low)
    too_high = high is not None and value > high
    if too_low or too_high:
        left = "(" if open_low else "["
        low_text = "-inf" if low is None else f"{low:g}"
        high_text = "inf" if high is None else f"{high:g}"
        raise ValueError(
            f"optimizer.{key}: {value!r} is out of range {left}{low_text}, {high_text}]"
        )
