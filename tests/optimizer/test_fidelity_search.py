"""The search spends a cheaper level (issue 38, item 4): the initial design at both levels,
multi-fidelity models where the level pays, the level of each run chosen by its worth per CPU
second, and the answer from fine runs only; a poorly correlated level is noticed and left."""

from __future__ import annotations

import numpy as np
import pytest

from demcal.engines.analytic import distorted
from demcal.optimizer import Optimizer
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.optimizer.surrogates.multi_fidelity import MultiFidelityKriging
from demcal.results.records import FINE
from demcal.scenes.cylinder_lift.analytic import analytic_model

FIXED = {
    "sliding_friction_pw": 0.5,
    "rolling_friction_pw": 0.1,
    "restitution_pp": 0.5,
    "particle_density": 2500.0,
}
TRUTH = {"sliding_friction_pp": 0.3, "rolling_friction_pp": 0.06}
KEYS = ("cylinder_lift.angle_of_repose", "cylinder_lift.bulk_density")
CPU = {FINE: 60.0, "coarse": 6.0}


def responses(x: list[float], level: dict, rng: np.random.Generator) -> dict[str, list[float]]:
    parameters = {**FIXED, "sliding_friction_pp": x[0], "rolling_friction_pp": x[1]}
    exact = distorted(analytic_model(parameters, {}), parameters, level)
    return {
        f"cylinder_lift.{name}": [exact[name] * (1.0 + 0.005 * rng.standard_normal())]
        for name in ("angle_of_repose", "bulk_density")
    }


def search(level: dict, budget: int = 10) -> Optimizer:
    truth = distorted(analytic_model({**FIXED, **TRUTH}, {}), {**FIXED, **TRUTH}, {})
    objective = ResponseObjective(
        (
            Target("cylinder_lift", "angle_of_repose", truth["angle_of_repose"], spread=0.3),
            Target("cylinder_lift", "bulk_density", truth["bulk_density"], spread=5.0),
        ),
        "precision",
    )
    optimizer = Optimizer(
        [0.1, 0.02],
        [0.9, 0.3],
        {
            "strategy": "response_ei",
            "max_evaluations": budget,
            "fidelity": "coarse",
            "stop_when_known": False,
            "kriging_restarts": 1,
        },
        seed=3,
        objective=objective,
    )
    rng = np.random.default_rng(5)
    while optimizer.stop_reason(0.0) is None:
        proposals = optimizer.ask(1)
        if not proposals:
            break
        (proposal,) = proposals
        at = {} if proposal.fidelity == FINE else level
        optimizer.tell(
            proposal.id,
            responses=responses(proposal.x, at, rng),
            cpu_s=CPU[proposal.fidelity],
        )
    return optimizer


@pytest.mark.slow
def test_a_correlated_cheap_level_teaches_the_search_and_never_gives_the_answer():
    optimizer = search({"scale": 0.9, "bias": {"angle_of_repose": 3.0}})
    initial = optimizer.initial_size
    cheap = optimizer.cheap_records
    assert sum(r.in_initial_design for r in cheap) == initial  # the design at both levels
    assert len(cheap) > initial  # and cheap runs chosen by their worth
    assert len(optimizer.records) == 10 and all(r.fidelity == FINE for r in optimizer.records)
    models = optimizer.response_predictor(levels=True).models
    assert all(isinstance(models[key], MultiFidelityKriging) for key in KEYS)
    fine_only = optimizer.response_predictor().models  # what the answer rests on
    assert not any(isinstance(model, MultiFidelityKriging) for model in fine_only.values())
    assert all(optimizer.level_verdicts()[key].pays for key in KEYS)
    best = optimizer.best()
    assert best.id in {r.id for r in optimizer.records}
    assert best.x[0] == pytest.approx(TRUTH["sliding_friction_pp"], abs=0.08)
    assert optimizer.level_cost("coarse") / optimizer.level_cost(FINE) == pytest.approx(0.1)
    resumed = Optimizer.from_json(optimizer.to_json(), optimizer.objective)
    assert [r.id for r in resumed.cheap_records] == [r.id for r in cheap]


@pytest.mark.slow
def test_a_poorly_correlated_level_is_noticed_and_only_its_initial_design_is_spent():
    optimizer = search({"ripple": 0.4})
    verdicts = optimizer.level_verdicts()
    assert verdicts and not any(v.pays for v in verdicts.values())
    assert len(optimizer.cheap_records) == optimizer.initial_size
    models = optimizer.response_predictor(levels=True).models
    assert not any(isinstance(model, MultiFidelityKriging) for model in models.values())
