"""Mapping the solution set after the search: the map_solutions phase and its strategy."""

import numpy as np
import pytest

from demcal.optimizer import Optimizer
from demcal.optimizer.membership import membership_probability
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.optimizer.responses import replicate_scatter


def angle(x):
    """A response of one combination of two parameters in [0, 1]²: any point on the line
    x0 + x1 = 1 meets the target, so the solution set is a band across the box."""
    return {"lift.angle": 20.0 + 20.0 * (x[0] + x[1])}


TARGET = Target("lift", "angle", 40.0, spread=0.5)


def run(optimizer, rng):
    while proposals := optimizer.ask(2):
        for proposal in proposals:
            value = angle(proposal.x)["lift.angle"] + 0.2 * rng.standard_normal()
            optimizer.tell(proposal.id, responses={"lift.angle": [value]})


def mapped_optimizer(**settings):
    return Optimizer(
        [0.0, 0.0],
        [1.0, 1.0],
        {
            "strategy": "response_ei",
            "max_evaluations": 12,
            "map_solutions": 8,
            "kriging_restarts": 1,
            **settings,
        },
        seed=5,
        objective=ResponseObjective((TARGET,)),
    )


def test_the_search_stops_then_the_set_is_mapped_then_the_run_stops():
    rng = np.random.default_rng(5)
    opt = mapped_optimizer(stop_when_known=False)  # the search runs its budget
    run(opt, rng)
    assert opt.completed_evaluations() == 12
    assert opt.stop_reason(0.0) is None  # the search ended: the mapping begins
    assert opt.search_ended == "evaluation budget reached (12 of 12)"
    resumed = Optimizer.from_json(opt.to_json(), opt.objective)
    assert resumed.search_ended == opt.search_ended
    run(opt, rng)
    mapped = [r for r in opt.records if r.maps_solutions]
    assert len(mapped) == 8 and opt.completed_evaluations() == 20
    assert opt.stop_reason(0.0) == (
        "evaluation budget reached (12 of 12); then 8 evaluations mapped the solution set"
    )


def test_the_answer_is_confirmed_before_the_set_is_mapped():
    """With confirm_replicates, the first points after the search repeat the best point, so
    the scatter they measure floors the models that choose the mapping points."""
    rng = np.random.default_rng(5)
    opt = mapped_optimizer(stop_when_known=False, confirm_replicates=2, map_solutions=3)
    run(opt, rng)
    assert opt.stop_reason(0.0) is None and opt.search_ended
    best = opt.best()
    first = opt.ask(1) + opt.ask(1)
    assert [p.confirms for p in first] == [best.id, best.id]
    assert all(p.x == pytest.approx(best.x) for p in first)
    for proposal in first:  # a scatter of 1.0, five times the noise the search saw
        opt.tell(proposal.id, responses={"lift.angle": [angle(best.x)["lift.angle"] + 1.0]})
    opt.tell(opt.ask(1)[0].id, responses={"lift.angle": [40.0]})
    assert opt.confirm() == [] and opt.best().id == best.id
    assert sum(r.maps_solutions for r in opt.records) == 1
    scatter = replicate_scatter(opt.records, "lift.angle")  # the best point's three runs
    assert scatter > 4 * 0.2**2  # the confirmations', not the search's noise of 0.2
    (model,) = opt.response_predictor().models.values()
    assert model.noise_sd >= np.sqrt(scatter) - 1e-9


def test_mapping_points_go_where_membership_is_undecided():
    """Each mapping point, when chosen, is one whose membership the models could not decide."""
    rng = np.random.default_rng(6)
    opt = mapped_optimizer(map_solutions=4)
    run(opt, rng)
    opt.stop_reason(0.0)
    for _ in range(4):
        (proposal,) = opt.ask(1)
        predictor = opt.response_predictor()
        unit = np.array([proposal.x])  # the box is the unit box
        means, stds = predictor.predict(unit)
        noise = {key: model.noise_sd for key, model in predictor.models.items()}
        p = membership_probability((TARGET,), means, stds, noise, 2.0)[0]
        assert 0.05 < p < 0.95
        assert not opt.early_termination(proposal.id, 1e9).stop  # a map point is never stopped
        value = angle(proposal.x)["lift.angle"] + 0.2 * rng.standard_normal()
        opt.tell(proposal.id, responses={"lift.angle": [value]})


def test_mapping_needs_the_targets():
    with pytest.raises(ValueError, match="optimizer.map_solutions: mapping the solution set"):
        Optimizer([0.0], [1.0], {"map_solutions": 4})
