"""The targets of a study file, checked and read: each a value with its spread (or repeats), a
bound or a goal, in the response's unit (converted from the unit the file gives), on a response
its scene measures and can reach."""

from __future__ import annotations

import math
import statistics
from typing import Any

from demcal.errors import ConfigError
from demcal.optimizer.objective import Target
from demcal.scenes import ResponseSpec, Scene
from demcal.study.schema import default
from demcal.study.units import CONVERSIONS, conversion_factor

#: The numbers of a target that are in its unit (``weight`` is not).
TARGET_QUANTITIES = ("value", "spread", "repeats", "at_least", "at_most", "discrepancy")


def _in_response_unit(
    target: dict[str, Any], index: int, unit: str
) -> tuple[dict[str, Any], str | None]:
    """``target`` with its numbers in ``unit``, its response's unit, and a note of the
    conversion or of a unit left out (None when neither); a ConfigError for a unit demcal
    cannot convert."""
    if "unit" not in target and unit != "-":
        return target, (
            f"targets[{index}]: no unit given; read as {unit}, the unit {target['response']} "
            f"is measured in"
        )
    given = target.get("unit", unit)
    factor = conversion_factor(given, unit)
    if factor is None:
        convertible = sorted(CONVERSIONS.get(unit, {}))
        raise ConfigError(
            f"targets[{index}].unit: {given!r} but {target['response']} is measured in {unit}; "
            f"give the value in {unit}"
            + (f" or in one of {', '.join(convertible)}" if convertible else "")
        )
    if factor == 1.0:
        return target, None
    converted = {
        key: [v * factor for v in value] if isinstance(value, list) else value * factor
        for key, value in target.items()
        if key in TARGET_QUANTITIES
    }
    shown = ", ".join(
        f"{key} {target[key]} {given} -> {_shown_number(converted[key])} {unit}"
        for key in converted
    )
    return {**target, **converted, "unit": unit}, f"targets[{index}]: converted {shown}"


def _shown_number(value: float | list[float]) -> str:
    if isinstance(value, list):
        return f"[{', '.join(f'{v:.4g}' for v in value)}]"
    return f"{value:.4g}"


def targets_of(config: dict[str, Any], scenes: dict[str, Scene]) -> tuple[list[Target], list[str]]:
    """The study's targets in their responses' units, and a note of each conversion."""
    targets, seen, notes = [], set(), []
    for i, t in enumerate(config["targets"]):
        scene = scenes[t["scene"]]
        if t["response"] not in scene.responses:
            raise ConfigError(
                f"targets[{i}].response: scene {scene.name!r} cannot produce "
                f"{t['response']!r}; it produces "
                f"{', '.join(scene.responses)}"
            )
        unit = scene.responses[t["response"]].unit
        t, note = _in_response_unit(t, i, unit)
        notes += [note] if note else []
        key = (t["scene"], t["response"])
        if key in seen:
            raise ConfigError(f"targets[{i}]: {t['scene']}.{t['response']} is targeted twice")
        seen.add(key)
        response = scene.responses[t["response"]]
        lower, upper = _target_bounds(t, i, response)
        tests = len(t["repeats"]) if "repeats" in t else int(t.get("tests", 1))
        if lower is None and upper is None:
            value, spread = _target_value(t, i)
            where = f"targets[{i}]{'' if 'repeats' in t else '.value'}"
            _check_possible(value, where, t["response"], response)
        else:
            value = next(bound for bound in (lower, upper) if bound is not None)
            spread = t.get("spread")
        if "tests" in t and spread is None:
            raise ConfigError(
                f"targets[{i}].tests: {t['tests']} tests of what scatter? give the spread of "
                f"single tests too (spread: ...), or the tests themselves (repeats: [...])"
            )
        targets.append(
            Target(
                t["scene"],
                t["response"],
                value,
                float(t.get("weight", default("targets", "weight"))),
                spread,
                lower,
                upper,
                tests,
                float(t.get("discrepancy", 0.0)),
            )
        )
    return targets, notes


def _check_possible(value: float, where: str, name: str, response: ResponseSpec) -> None:
    """ConfigError unless ``response`` (named ``name``) can take ``value`` (given at
    ``where``)."""
    if not response.lower <= value <= response.upper:
        raise ConfigError(
            f"{where}: {value:g} {response.unit} is not a possible {name}; it lies in "
            f"[{response.lower:g}, {response.upper:g}] {response.unit}"
        )


def _target_bounds(
    target: dict[str, Any], index: int, response: ResponseSpec
) -> tuple[float | None, float | None]:
    """The bounds of a target given as ``at_least``/``at_most`` or as a ``goal`` (a target at
    the response's own bound); (None, None) for a target ``value`` or ``repeats``."""
    kinds = [
        name
        for name, keys in (
            ("value", ("value", "repeats")),
            ("bounds", ("at_least", "at_most")),
            ("goal", ("goal",)),
        )
        if any(k in target for k in keys)
    ]
    if len(kinds) > 1:
        raise ConfigError(
            f"targets[{index}]: give one of a value (value or repeats), bounds (at_least, "
            f"at_most) or a goal (minimise, maximise), not {' and '.join(kinds)}"
        )
    where = f"targets[{index}]"
    if "goal" in target:
        goal = response.lower if target["goal"] == "minimise" else response.upper
        if not math.isfinite(goal):
            raise ConfigError(
                f"{where}.goal: {target['response']} has no {'lowest' if goal < 0 else 'highest'}"
                f" possible value to {target['goal']} it towards; give a value to reach or bounds"
                f" (at_least, at_most)"
            )
        return (None, goal) if target["goal"] == "minimise" else (goal, None)
    lower, upper = target.get("at_least"), target.get("at_most")
    for name, bound in (("at_least", lower), ("at_most", upper)):
        if bound is not None:
            _check_possible(float(bound), f"{where}.{name}", target["response"], response)
    if lower is not None and upper is not None and not lower < upper:
        raise ConfigError(
            f"{where}.at_most: {upper:g} {response.unit} is not above at_least "
            f"({lower:g} {response.unit})"
        )
    return (
        None if lower is None else float(lower),
        None if upper is None else float(upper),
    )


def _target_value(target: dict[str, Any], index: int) -> tuple[float, float | None]:
    """The target's value and spread: as given, or the mean and standard
    deviation of its repeats."""
    if "repeats" not in target:
        if "value" not in target:
            raise ConfigError(
                f"targets[{index}]: give the measured value (value: ..., optionally "
                f"spread: ...) or the lab test's repeats (repeats: [..., ...])"
            )
        return float(target["value"]), target.get("spread")
    given = [key for key in ("value", "spread", "tests") if key in target]
    if given:
        raise ConfigError(
            f"targets[{index}].{given[0]}: given together with repeats, which "
            f"determine it (their mean, standard deviation and number); give one or the other"
        )
    repeats = target["repeats"]
    try:  # exact arithmetic: a float sum of large repeats would overflow where their mean does not
        value, spread = float(statistics.mean(repeats)), float(statistics.stdev(repeats))
    except OverflowError:
        value, spread = math.inf, math.inf
    if not math.isfinite(spread):
        raise ConfigError(
            f"targets[{index}].repeats: their standard deviation is beyond the "
            f"largest float ({max(repeats, key=abs):g} among them); give the repeats "
            f"in the response's unit"
        )
    return value, spread
