"""Rackl & Hanley's (2017) calibration procedure as an asynchronous strategy.

Three phases (their Fig. 2, sec. 2.3 and 2.4):

1. sampling: a Latin hypercube of 3 points per parameter (their recommended
   SPP = 3, sec. 3.5) — the optimizer's initial design, sized by the
   registry entry;
2. Levenberg–Marquardt on the metamodels: one Kriging model per response,
   least squares of the residuals of eq. 9, started from the centre of the
   box (:func:`metamodel_minimum`);
3. Levenberg–Marquardt on the DEM itself, started from the metamodels'
   optimum: each iteration simulates a trial point and its forward
   finite-difference steps together, so the d + 1 simulations of an
   iteration run in parallel; the step is accepted if the trial lowers the
   objective, and the procedure stops when an accepted step improves the
   objective by less than 2 % (their termination rule).

The Levenberg–Marquardt step is Marquardt's scaled one (:func:`lm_step`),
projected onto the box. Their Rayleigh time-step term (eq. 10) is not
modelled by the response models, so studies with it use the scalar
strategies. Early termination never stops these evaluations (registry:
``stops_early``): every finite-difference point is needed.

What the procedure must remember between proposals lives in
``history.strategy_state`` (saved with the optimizer): the accepted iterate
with its residuals and Jacobian, the damping, the points of the running
iteration and the run counts of each phase.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from demcal.optimizer.objective import ResponseObjective, weighted_residuals
from demcal.results.records import Status

from ..responses import ResponsePredictor
from .base import History, Strategy

#: Forward finite-difference step in the unit box: large enough that simulation noise does not
#: swamp the difference (Octave's default of 0.1 % of the value would measure only noise).
FD_STEP = 0.05
#: Stop when an accepted step lowers the objective by less than this share (Rackl & Hanley 2017).
IMPROVEMENT_TO_CONTINUE = 0.02
#: Marquardt's damping: start, factor on rejection (and 1/factor on acceptance), largest before
#: giving up.
DAMPING_START, DAMPING_FACTOR, DAMPING_MAX = 1e-2, 10.0, 1e6
#: Steps shorter than this (unit box) cannot move the iterate any more.
SMALLEST_STEP = 1e-6


def metamodel_minimum(predictor: ResponsePredictor, dimension: int) -> np.ndarray:
    """Least squares of the predicted residuals from the centre of the box (phase 2).

    SciPy's bounded trust-region form of Levenberg–Marquardt (``trf``): the
    unbounded ``lm`` method would leave the parameter box.
    """
    objective = predictor.objective

    def residuals(u: np.ndarray) -> np.ndarray:
        means, _ = predictor.predict(u[None, :])
        return weighted_residuals(
            objective.targets, {key: value[0] for key, value in means.items()}, objective.form
        )

    fit = least_squares(residuals, np.full(dimension, 0.5), bounds=(0.0, 1.0), method="trf")
    minimum: np.ndarray = fit.x
    return minimum


def stencil(point: np.ndarray) -> list[np.ndarray]:
    """The forward finite-difference points of ``point`` (backward where the box ends)."""
    steps = []
    for j in range(len(point)):
        step = point.copy()
        step[j] += FD_STEP if point[j] + FD_STEP <= 1.0 else -FD_STEP
        steps.append(step)
    return steps


def jacobian(
    point: np.ndarray,
    residual: np.ndarray,
    steps: list[np.ndarray],
    step_residuals: list[np.ndarray],
) -> np.ndarray:
    """Finite-difference Jacobian (responses x parameters) from the stencil's residuals."""
    columns = [
        (r - residual) / (s - point)[j] for j, (s, r) in enumerate(zip(steps, step_residuals))
    ]
    return np.column_stack(columns)


def lm_step(point: np.ndarray, residual: np.ndarray, jac: np.ndarray, damping: float) -> np.ndarray:
    """Marquardt's step (J'J + λ diag(J'J)) δ = -J'r, projected onto the unit box.

    A small multiple of the identity keeps the system solvable when there
    are fewer responses than parameters (J'J singular).
    """
    normal = jac.T @ jac
    scale = np.diag(normal) + 1e-9 * max(float(np.max(np.diag(normal))), 1e-12)
    delta = np.linalg.solve(normal + damping * np.diag(scale), -jac.T @ residual)
    step: np.ndarray = np.clip(point + delta, 0.0, 1.0)
    return step


def _find(history: History, point: ArrayLike) -> int | None:
    """Index in the history of the evaluation at ``point`` (proposed by this strategy), or None."""
    hits = np.flatnonzero(np.all(np.abs(history.points - np.asarray(point)) <= 1e-12, axis=1))
    return int(hits[-1]) if len(hits) else None


class RacklHanley(Strategy):
    """Rackl & Hanley's procedure; see the module docstring."""

    def propose(self, history: History) -> np.ndarray | None:
        state = history.strategy_state
        if state.get("stop_reason"):
            return None
        if state.get("queue"):
            return self._hand_out(state)
        if "iteration" not in state:  # phase 2, once the sampling is told
            predictor = history.responses
            if predictor is None:
                return (
                    history.space_filling_point()
                    if Status.PENDING not in history.statuses
                    else None
                )
            state.update(
                damping=DAMPING_START, iterations=0, dem_runs=0, sampling_runs=history.handed_out
            )
            return self._start_iteration(state, metamodel_minimum(predictor, history.dimension))
        return self._next_iteration(history, state)

    @staticmethod
    def _hand_out(state: dict[str, Any]) -> np.ndarray:
        state["dem_runs"] += 1
        return np.array(state["queue"].pop(0))

    def _start_iteration(self, state: dict[str, Any], trial: np.ndarray) -> np.ndarray:
        points = [trial, *stencil(trial)]
        state["iteration"] = [p.tolist() for p in points]
        state["queue"] = [p.tolist() for p in points]
        return self._hand_out(state)

    def _next_iteration(self, history: History, state: dict[str, Any]) -> np.ndarray | None:
        found = [_find(history, p) for p in state["iteration"]]
        indices = [i for i in found if i is not None]
        if len(indices) < len(found) or any(history.statuses[i] == Status.PENDING for i in indices):
            return None  # the iteration's simulations are still running
        trial, *steps = (np.array(p) for p in state["iteration"])
        objective = history.responses.objective if history.responses else None
        residual = self._residual(history, indices[0], objective)
        accepted = state.get("accepted")
        if residual is not None and (accepted is None or residual @ residual < accepted["value"]):
            measured = [self._residual(history, i, objective) for i in indices[1:]]
            step_residuals = [
                r if r is not None else self._predicted_residual(history, s)
                for r, s in zip(measured, steps)
            ]
            value = float(residual @ residual)
            previous = None if accepted is None else accepted["value"]
            state["accepted"] = {
                "x": trial.tolist(),
                "value": value,
                "residual": residual.tolist(),
                "jacobian": jacobian(trial, residual, steps, step_residuals).tolist(),
            }
            state["damping"] = state["damping"] / DAMPING_FACTOR
            state["iterations"] += 1
            if previous is not None and (previous - value) < IMPROVEMENT_TO_CONTINUE * previous:
                return self._stop(
                    state,
                    f"improvement {100 * (previous - value) / previous:.1f} % < "
                    f"{100 * IMPROVEMENT_TO_CONTINUE:.0f} %",
                )
        else:
            state["damping"] = state["damping"] * DAMPING_FACTOR
            if state["damping"] > DAMPING_MAX or state.get("accepted") is None:
                return self._stop(state, "no step lowers the objective")
        accepted = state["accepted"]
        point = np.array(accepted["x"])
        trial = lm_step(
            point, np.array(accepted["residual"]), np.array(accepted["jacobian"]), state["damping"]
        )
        if np.linalg.norm(trial - point) < SMALLEST_STEP:
            return self._stop(state, "the step is below resolution")
        return self._start_iteration(state, trial)

    @staticmethod
    def _residual(
        history: History, index: int, objective: ResponseObjective | None
    ) -> np.ndarray | None:
        means = history.response_means[index]
        if objective is None or not means or any(key not in means for key in objective.keys):
            return None
        return weighted_residuals(objective.targets, means, objective.form)

    @staticmethod
    def _predicted_residual(history: History, point: np.ndarray) -> np.ndarray:
        """A failed finite-difference point's residuals, as the response models predict them."""
        predictor = history.responses
        assert predictor is not None, "residuals were measured, so the response models exist"
        means, _ = predictor.predict(point[None, :])
        return weighted_residuals(
            predictor.objective.targets,
            {k: v[0] for k, v in means.items()},
            predictor.objective.form,
        )

    @staticmethod
    def _stop(state: dict[str, Any], why: str) -> None:
        state["stop_reason"] = (
            f"Rackl & Hanley's Levenberg–Marquardt on the simulations ended ({why}) after "
            f"{state['iterations']} accepted iterations; runs: {state['sampling_runs']} sampling, "
            f"{state['dem_runs']} Levenberg–Marquardt on the simulations"
        )
        return None
