"""Early termination of hopeless evaluations (Samuelsson 2023, section 3.6).

While a simulation runs, a partial estimate eta_et of its objective (for
example the relative error of a response that is known early, or the error
of the first of several replicates) is compared with the current best value
f*: the run is stopped if eta_et > c * f* (eq. 3.4). The factor c falls as
the optimization proceeds: with the thesis' pattern c = 10 during the first
half of the evaluations after the initial design, 5 during the third
quarter and 2.5 for the rest. Runs of the initial design are never stopped.
The rule assumes a non-negative objective (a sum of squared errors).
:func:`reference` is the f* the optimizer compares with.

The ``weighed`` rule (demcal's default; ``eq_3_4`` is the thesis' alone)
keeps that limit and weighs what stopping saves: a run with a share
``done`` of its simulation work behind it is stopped only when its
estimate exceeds the limit divided by the share left, 1 - done, so the
less there is to save, the surer the run must be hopeless; a run in its
last stretch is finished, whatever the limit did meanwhile. An estimate
that falls as the run goes on is judged by where its trend heads at the
end of the run (:func:`estimate_heading`), never by a rising trend.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from demcal.optimizer.objective import objective_values

from .responses import ESTIMATE_RELATIVE_SD, replicate_scatter
from .settings import EarlyTerminationSettings

if TYPE_CHECKING:
    from demcal.optimizer.objective import ResponseObjective

    from .evaluation import BestPoint, Evaluation
    from .responses import ResponsePredictor


#: The defaults of the rule's settings (Samuelsson 2023, Table 4.2), for a call without them.
DEFAULTS = EarlyTerminationSettings()


@dataclass(frozen=True)
class RunProgress:
    """Where a running evaluation stands: ``done``, the share of its simulation work behind
    it (0-1), ``heading``, where its estimate's trend points at the end of the run (None
    without a trend), ``estimated``, the targeted responses (``scene.response``) its
    estimate covers (empty: not known, as all), and ``provisional``, those of them not final
    yet (early estimates)."""

    done: float
    heading: float | None = None
    estimated: tuple[str, ...] = ()
    provisional: tuple[str, ...] = ()


def estimate_heading(
    history: Sequence[tuple[float, float]], points: int = 5, min_span: float = 0.05
) -> float | None:
    """Where a run's objective estimate heads at the end of the run: the least-squares line
    through its last ``points`` (share done, estimate) pairs, at share 1.

    None with fewer than three pairs, or when they span less than ``min_span`` of the run.
    """
    recent = np.asarray(history[-points:], float)
    if len(recent) < 3 or np.ptp(recent[:, 0]) < min_span:
        return None
    slope, intercept = np.polyfit(recent[:, 0], recent[:, 1], 1)
    return float(slope + intercept)


@dataclass(frozen=True)
class EarlyTerminationDecision:
    """``stop`` is the verdict; ``factor`` the c used; ``limit`` what the estimate was held to
    (c f*, weighed by the work left; None if no limit applied); ``judged`` the estimate
    compared with it (the partial estimate, or where its falling trend heads); ``reason``
    explains it."""

    stop: bool
    factor: float | None
    reason: str
    limit: float | None = None
    judged: float | None = None


def termination_factor(
    progress: float,
    thresholds: Sequence[float] = (10.0, 5.0, 2.5),
    progress_boundaries: Sequence[float] = (0.5, 0.75),
) -> float:
    """The factor c for a ``progress`` in [0, 1] of the adaptive budget.

    ``thresholds[k]`` applies from ``progress_boundaries[k-1]`` (inclusive)
    up to ``progress_boundaries[k]`` (exclusive).
    """
    for factor, boundary in zip(thresholds, progress_boundaries):
        if progress < boundary:
            return float(factor)
    return float(thresholds[-1])


def early_termination_decision(
    best_value: float | None,
    partial_estimate: float,
    progress: float,
    in_initial_design: bool = False,
    enabled: bool = DEFAULTS.enabled,
    thresholds: Sequence[float] = DEFAULTS.thresholds,
    progress_boundaries: Sequence[float] = DEFAULTS.progress_boundaries,
    run: RunProgress | None = None,
    rule: str = DEFAULTS.rule,
    last_stretch: float = DEFAULTS.last_stretch,
) -> EarlyTerminationDecision:
    """Decide whether to stop a running evaluation (eq. 3.4: stop if eta_et > c f*).

    ``progress`` is the fraction of the optimizer's evaluation budget used
    after the initial design (0 at its end, 1 when the budget is spent).
    With ``run`` (where the evaluation stands) and the ``weighed`` rule the
    work left is weighed (module docstring); without ``run``, eq. 3.4 alone.
    """
    if not enabled:
        return EarlyTerminationDecision(False, None, "early termination disabled")
    if in_initial_design:
        return EarlyTerminationDecision(False, None, "initial design is never terminated")
    if best_value is None:
        return EarlyTerminationDecision(False, None, "no best value yet")
    factor = termination_factor(min(max(progress, 0.0), 1.0), thresholds, progress_boundaries)
    limit = factor * best_value
    bound = f"{factor:g} x best {best_value:g}"
    estimate = partial_estimate
    if rule == "weighed" and run is not None:
        done = min(max(run.done, 0.0), 1.0)
        if done >= last_stretch:
            return EarlyTerminationDecision(
                False, factor, f"in its last stretch ({done:.0%} done): finished"
            )
        if run.heading is not None and run.heading < estimate:
            estimate = max(run.heading, 0.0)
        limit /= 1.0 - done
        bound = f"{bound} / {1.0 - done:.2f} left"
    stop = estimate > limit
    judged = f"partial estimate {partial_estimate:g}" + (
        f" heading to {estimate:g}" if estimate != partial_estimate else ""
    )
    return EarlyTerminationDecision(
        stop, factor, f"{judged} {'>' if stop else '<='} {bound}", limit, estimate
    )


def reference(
    best: BestPoint | None,
    best_observed: float | None,
    records: list[Evaluation],
    predictor: Callable[[], ResponsePredictor | None],
    objective: ResponseObjective | None,
    run: RunProgress | None = None,
) -> float | None:
    """The best objective f* a running evaluation is compared with (thesis eq. 3.4).

    With response models (``best`` chosen by them): their best prediction at
    an evaluated point plus the objective's noise floor, the larger of the
    mean objective of the models' residuals at the evaluated points and
    :func:`estimate_noise` of the responses the ``run``'s estimate covers
    (what noise alone puts into it). A lucky noisy sample does
    not set the bar, and once the best prediction is below the noise, a run
    is not stopped for being as noisy as every run is. Else
    ``best_observed``, the best observed value.
    """
    if best is None or best.chosen_by != "response models":
        return best_observed
    best_predicted = best.predicted
    finished = [r for r in records if r.finished and r.responses]
    if not finished:
        return best_predicted
    models = predictor()
    assert models is not None and objective is not None, "best was chosen by the response models"
    predicted, _ = models.predict(np.array([r.x for r in finished]))
    residuals = {
        key: target.missed_by(
            np.abs(np.array([r.responses[key].mean for r in finished]) - predicted[key])
        )
        for key, target in zip(objective.keys, objective.targets)
    }
    covered = RunProgress(0.0) if run is None else run
    floor = max(
        float(np.mean(objective(residuals))),
        estimate_noise(finished, objective, covered.estimated, covered.provisional),
    )
    return best_predicted + floor


def estimate_noise(
    records: list[Evaluation],
    objective: ResponseObjective,
    estimated: Sequence[str] = (),
    provisional: Sequence[str] = (),
) -> float:
    """What noise alone puts into the objective estimate of a running evaluation at the
    targets: eq. 3.3 over the ``estimated`` responses (all when empty), each one standard
    deviation off its target, that of one simulation (``replicate_scatter``, pooled over the
    replicated points) and, for a ``provisional`` one, of an early estimate
    (``ESTIMATE_RELATIVE_SD`` of the target) combined.

    A running evaluation is judged by the early estimates of the simulations reporting so
    far (in a staged study replicate 0 alone, as Samuelsson 2023, sec. 5.1.2, judged the
    first of five): as noisy as one run and then some, while the best it is compared with
    is a mean over every replicate of finished runs.
    """
    targets = [t for t in objective.targets if not estimated or t.key in estimated]
    off = {
        t.key: t.missed_by(
            np.sqrt(
                replicate_scatter(records, t.key)
                + (ESTIMATE_RELATIVE_SD * t.value * (t.key in provisional)) ** 2
            )
        )
        for t in targets
    }
    return float(objective_values(targets, off, objective.form))
