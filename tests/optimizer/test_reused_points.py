"""Points reused from the archive: data for the models, outside the budget, saved with the state."""

import json

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from demcal.optimizer import Optimizer
from demcal.optimizer.designs import fill_gaps
from demcal.optimizer.evaluation import ReusedPoint
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.results.records import Status

OBJECTIVE = ResponseObjective((Target("s", "a", 1.0), Target("s", "b", 2.0)))


def responses(x: list[float]) -> dict[str, float]:
    return {"s.a": 0.5 + x[0], "s.b": 1.0 + 2.0 * x[1]}


def reused(points: list[list[float]]) -> list[ReusedPoint]:
    out = []
    for i, x in enumerate(points):
        values = responses(x)
        out.append(
            ReusedPoint(
                x,
                {key: [value] for key, value in values.items()},
                OBJECTIVE.of_means(values),
                None,
                f"old/e{i:04d}",
            )
        )
    return out


def optimizer(points: list[list[float]], max_evaluations: int = 4) -> Optimizer:
    return Optimizer(
        [0.0, 0.0],
        [1.0, 1.0],
        {"strategy": "response_ei", "max_evaluations": max_evaluations},
        seed=2,
        objective=OBJECTIVE,
        reused=reused(points),
    )


def test_reused_points_cut_the_design_to_what_is_missing():
    assert optimizer([]).initial_size == 5
    some = optimizer([[0.1, 0.1], [0.9, 0.9]])
    assert some.initial_size == len(some.design_queue) == 3
    enough = optimizer([[0.1, 0.1], [0.9, 0.9], [0.1, 0.9], [0.9, 0.1], [0.5, 0.5]])
    assert enough.initial_size == 0 and enough.design_queue == []
    assert not enough.ask(1)[0].in_initial_design


def test_the_missing_design_points_fill_the_holes_of_the_reused_ones():
    covered = np.array([[0.1, 0.1], [0.2, 0.15], [0.15, 0.3]])
    filled = fill_gaps(covered, 3, 2, np.random.default_rng(0))
    assert filled.shape == (3, 2)
    assert cdist(filled, covered).min() > 0.6  # far from the crowded corner
    assert cdist(filled, filled)[np.triu_indices(3, 1)].min() > 0.5


def test_reused_points_are_data_outside_the_budget():
    opt = optimizer([[0.1, 0.1], [0.9, 0.9], [0.1, 0.9], [0.9, 0.1], [0.5, 0.5]], 3)
    assert opt.reused_points == 5
    assert opt.completed_evaluations() == 0 and opt.status_counts() == {}
    assert opt.response_predictor() is not None  # the models have their data before any run
    assert opt.best_observed == min(r.value for r in opt.records)
    for proposal in [opt.ask(1)[0] for _ in range(3)]:
        assert proposal.id >= 5
        opt.tell(proposal.id, responses={k: [v] for k, v in responses(proposal.x).items()})
    assert opt.ask(1) == [] and opt.completed_evaluations() == 3
    assert opt.stop_reason(0.0) is not None
    assert opt.status_counts() == {Status.OK: 3}


def test_the_answer_may_be_a_reused_point_and_names_its_source():
    best = optimizer([[0.5, 0.5], [0.1, 0.9], [0.9, 0.1], [0.2, 0.2]]).best()
    assert best is not None and best.reused_from == "old/e0000" and best.x == [0.5, 0.5]


def test_the_state_keeps_the_reused_points():
    opt = optimizer([[0.1, 0.1], [0.9, 0.9]])
    text = opt.to_json()
    records = json.loads(text)["records"]
    assert [r.get("reused_from") for r in records] == ["old/e0000", "old/e0001"]
    again = Optimizer.from_json(text, OBJECTIVE)
    assert again.records == opt.records and again.reused_points == 2
    assert again.ask(2) == opt.ask(2)


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_a_reused_point_without_a_finite_objective_is_recorded_as_failed(value):
    point = ReusedPoint([0.5, 0.5], {"s.a": [1.0], "s.b": [2.0]}, value, None, "old/e0000")
    opt = Optimizer([0.0, 0.0], [1.0, 1.0], {}, objective=OBJECTIVE, reused=[point])
    assert opt.records[0].status == Status.FAILED
