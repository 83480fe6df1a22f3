"""Rackl & Hanley's procedure: LHS of 3 per parameter, LM on the Kriging models, then LM
on the simulations."""

import json

import numpy as np
import pytest

from demcal.optimizer import Optimizer
from demcal.optimizer.objective import ResponseObjective, Target, objective_values
from demcal.optimizer.strategies.rackl_hanley import FD_STEP, jacobian, lm_step, stencil

LOWER, UPPER = [0.1, 0.02], [0.9, 0.3]


def lift(x):
    """Angle of repose and bulk density of (sliding, rolling) friction, smooth and monotone."""
    mu, mr = x
    return {
        "lift.angle": 12.0 + 30.0 * (1.0 - np.exp(-mu / 0.35)) + 25.0 * mr,
        "lift.density": 1600.0 - 180.0 * mu - 150.0 * mr,
    }


TRUTH = (0.4, 0.1)
TARGETS = tuple(Target("lift", key.split(".")[1], value) for key, value in lift(TRUTH).items())


def optimizer(budget=60):
    return Optimizer(
        LOWER,
        UPPER,
        {"strategy": "rackl_hanley", "max_evaluations": budget},
        seed=2,
        objective=ResponseObjective(TARGETS),
    )


def tell(opt, proposal, noise=0.0, rng=None):
    opt.tell(
        proposal.id,
        responses={
            key: [value * (1 + noise * rng.standard_normal()) if noise else value]
            for key, value in lift(proposal.x).items()
        },
    )


def test_lm_step_solves_a_linear_least_squares_problem_in_one_undamped_step():
    a = np.array([[2.0, 1.0], [0.5, 3.0], [1.0, 1.0]])
    b = np.array([1.2, 1.9, 0.9])
    point = np.array([0.2, 0.2])
    steps = stencil(point)
    jac = jacobian(point, a @ point - b, steps, [a @ s - b for s in steps])
    assert jac == pytest.approx(a)
    assert lm_step(point, a @ point - b, jac, 1e-12) == pytest.approx(
        np.linalg.lstsq(a, b, rcond=None)[0]
    )


def test_the_phases_run_in_order_and_each_iteration_runs_its_steps_in_parallel():
    opt = optimizer()
    design = opt.ask(100)
    assert len(design) == 6 and all(p.in_initial_design for p in design)  # 3 per parameter
    for proposal in design:
        tell(opt, proposal)
    first = opt.ask(10)  # the metamodels' optimum and its two finite-difference steps, at once
    assert len(first) == 3
    trial, *steps = (np.array(opt.bounds.to_unit(p.x)[0]) for p in first)
    assert [np.abs(s - trial).max() for s in steps] == pytest.approx([FD_STEP, FD_STEP])
    assert (
        np.linalg.norm(np.array(first[0].x) - TRUTH) < 0.1
    )  # the Kriging models already point there
    assert opt.ask(1) == []  # the next iteration waits for these three
    assert not opt.early_termination(first[0].id, 1e9).stop  # every step must finish
    tell(opt, first[0])
    tell(opt, first[1])
    resumed = Optimizer.from_json(
        opt.to_json(), opt.objective
    )  # mid-iteration, through the saved state
    assert resumed.strategy_state == json.loads(opt.to_json())["strategy_state"]
    tell(resumed, first[2])
    assert len(resumed.ask(10)) == 3


@pytest.mark.slow
def test_with_noise_it_stops_on_its_own_at_the_noise_level_and_counts_the_runs_of_each_phase():
    """0.5 % simulation noise: once the objective is down at the noise, no step improves it by 2 %.

    The two responses trade sliding against rolling friction along a shallow
    valley, so the answer is judged by its true objective, not its distance to TRUTH.
    """
    opt, rng = optimizer(), np.random.default_rng(4)
    while proposals := opt.ask(
        3
    ):  # told at once: an empty ask means it stopped (the daemon then asks why)
        for proposal in proposals:
            tell(opt, proposal, 0.005, rng)
    reason = opt.stop_reason(0.0)
    assert "Levenberg–Marquardt on the simulations ended" in reason
    state = opt.strategy_state
    assert f"runs: 6 sampling, {state['dem_runs']} Levenberg–Marquardt" in reason
    assert opt.completed_evaluations() == 6 + state["dem_runs"] < 60
    noise_level = 2 * 0.005**2
    assert objective_values(TARGETS, lift(opt.best().x)) < noise_level
