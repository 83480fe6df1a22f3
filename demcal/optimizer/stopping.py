"""Stopping rules of an optimization run, checked in a fixed order.

Each rule is off when its limit is None. The trust-region rule fires when
the MSRS/DYCORS step size would fall below sigma_min (Samuelsson 2023,
section 3.5.1.2: the point where a restart would otherwise be considered).
"""

from __future__ import annotations


def stop_reason(
    evaluations: int,
    max_evaluations: int,
    elapsed_seconds: float,
    max_seconds: float | None,
    best_value: float | None,
    target_objective: float | None,
    evaluations_without_improvement: int,
    no_improvement_evaluations: int | None,
    step_collapsed: bool,
) -> str | None:
    """The first stopping rule that holds, as a short sentence, or None to go on."""
    if evaluations >= max_evaluations:
        return f"evaluation budget reached ({evaluations} of {max_evaluations})"
    if max_seconds is not None and elapsed_seconds >= max_seconds:
        return f"wall-clock budget reached ({elapsed_seconds:.0f} s of {max_seconds:g} s)"
    if target_objective is not None and best_value is not None and best_value <= target_objective:
        return f"target objective reached ({best_value:g} <= {target_objective:g})"
    if (
        no_improvement_evaluations is not None
        and evaluations_without_improvement >= no_improvement_evaluations
    ):
        return f"no improvement for {evaluations_without_improvement} evaluations"
    if step_collapsed:
        return "trust region collapsed (step size below sigma_min)"
    return None
