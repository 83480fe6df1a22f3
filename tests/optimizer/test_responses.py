"""Responses as the optimizer's data: per-response models, the objective on top,
stopped runs that teach."""

import dataclasses

import numpy as np
import pytest

from demcal.optimizer import Optimizer
from demcal.optimizer.evaluation import ObservedResponse
from demcal.optimizer.objective import ResponseObjective, Target, objective_values
from demcal.optimizer.responses import ResponseModels, observations


def lift(x):
    """A cylinder-lift-like pair of responses over (sliding, rolling) friction in [0.1,
    0.9] x [0.02, 0.3]."""
    mu, mr = x
    return {
        "lift.angle": 12.0 + 30.0 * (1.0 - np.exp(-mu / 0.35)) + 25.0 * mr,
        "lift.density": 1600.0 - 180.0 * mu - 150.0 * mr,
    }


TRUTH = lift((0.4, 0.1))  # angle 34.9 deg, density 1513 kg/m^3
TARGETS = (
    Target("lift", "angle", TRUTH["lift.angle"], spread=1.5),
    Target("lift", "density", TRUTH["lift.density"], spread=4.0),
)


def optimizer(strategy="response_ei", form="relative", **settings):
    return Optimizer(
        [0.1, 0.02],
        [0.9, 0.3],
        {"strategy": strategy, "max_evaluations": 40, **settings},
        seed=3,
        objective=ResponseObjective(TARGETS, form),
    )


def test_the_value_told_is_the_objective_of_the_responses():
    opt = optimizer()
    proposal = opt.ask(1)[0]
    responses = {"lift.angle": [34.0, 36.5], "lift.density": [1505.0, 1517.0]}
    opt.tell(proposal.id, responses=responses)
    record = opt.records[0]
    means = {k: np.mean(v) for k, v in responses.items()}
    assert record.value == pytest.approx(objective_values(TARGETS, means))
    per_replicate = [
        objective_values(TARGETS, {k: v[i] for k, v in responses.items()}) for i in (0, 1)
    ]
    assert record.variance == pytest.approx(np.var(per_replicate, ddof=1) / 2)
    assert record.responses["lift.angle"] == ObservedResponse((34.0, 36.5), final=True)


def test_precision_form_counts_errors_in_target_spreads():
    value = objective_values(
        TARGETS,
        {"lift.angle": TRUTH["lift.angle"] + 1.5, "lift.density": TRUTH["lift.density"] - 4.0},
        "precision",
    )
    assert value == pytest.approx(1.0 + 1.0)  # one spread off in each response


def test_a_stopped_run_teaches_what_it_completed_and_estimated():
    opt = optimizer()
    for proposal in opt.ask(3):
        opt.tell(
            proposal.id,
            status="terminated",
            partial={
                "lift.density": {"values": [1500.0], "final": True},
                "lift.angle": {"values": [30.0], "final": False},
            },
        )
    x, y, variance = observations(opt.records, "lift.density", 2)
    assert len(y) == 3 and np.all(variance == 0.0)  # final values: as good as finished ones
    x, y, variance = observations(opt.records, "lift.angle", 2)
    assert len(y) == 3 and np.all(variance > 0.0)  # estimates carry their own uncertainty
    assert all(r.value is None for r in opt.records)  # no objective value was invented


def test_models_are_refitted_only_on_new_data():
    opt = optimizer()
    for proposal in opt.ask(6):
        opt.tell(proposal.id, responses={k: [v] for k, v in lift(proposal.x).items()})
    models = ResponseModels("kriging", 1e-7, 1, 0)
    first = models.fit(opt.records, ["lift.angle", "lift.density"], 2)
    again = models.fit(opt.records, ["lift.angle", "lift.density"], 2)
    assert all(first[k] is again[k] for k in first)


@pytest.mark.slow
def test_a_refit_starts_from_the_last_length_scales_and_nugget_unless_that_fit_was_degenerate():
    """A warm start of the length scales alone restarted the nugget near 0 and the single start
    stayed there, or ran off to a nugget of 1e10 (only the trend left, the early-termination
    limit 9 times too lax in the quickstart's replay): the nugget is carried over too, and a
    degenerate fit is followed by a full refit."""
    rng = np.random.default_rng(4)
    opt = optimizer()
    for proposal in opt.ask(8):
        noisy = {k: [v * (1.0 + 0.01 * rng.standard_normal())] for k, v in lift(proposal.x).items()}
        opt.tell(proposal.id, responses=noisy)
    models = ResponseModels("kriging", 1e-7, 3, 0)
    first = models.fit(opt.records, ["lift.density"], 2)["lift.density"]
    theta, nugget = first.warm_start
    assert nugget == pytest.approx(float(np.ravel(first.model.optimal_noise)[0]))
    opt.tell(opt.ask(1)[0].id, responses={k: [v] for k, v in lift((0.5, 0.2)).items()})
    warm = models.fit(opt.records, ["lift.density"], 2)["lift.density"]
    assert warm.restarts == 1 and warm.start[1] == pytest.approx(max(nugget, 1e-6))
    warm.model.optimal_noise = np.array([1e10])  # as the degenerate fit left it
    assert warm.warm_start is None
    opt.tell(opt.ask(1)[0].id, responses={k: [v] for k, v in lift((0.3, 0.1)).items()})
    after = models.fit(opt.records, ["lift.density"], 2)["lift.density"]
    assert after.restarts == 3 and after.start is None


def test_best_is_the_evaluated_point_with_the_lowest_predicted_objective():
    rng = np.random.default_rng(0)
    opt = optimizer(strategy="dycors")
    assert opt.best() is None
    for proposal in opt.ask(12):
        noisy = {k: [v * (1 + 0.01 * rng.standard_normal())] for k, v in lift(proposal.x).items()}
        opt.tell(proposal.id, responses=noisy)
    best = opt.best()
    assert best.chosen_by == "response models"
    finished = [r for r in opt.records if r.finished]
    predicted = opt.response_predictor().objective_mean(np.array([r.x for r in finished]))
    assert best.id == finished[int(np.argmin(predicted))].id
    assert best.predicted == pytest.approx(predicted.min())
    means, stds = opt.response_predictor().predict(
        np.array([finished[int(np.argmin(predicted))].x])
    )
    assert best.responses == {key: pytest.approx((means[key][0], stds[key][0])) for key in means}


@pytest.mark.slow
def test_a_best_point_on_a_bound_is_flagged_in_best_and_in_the_summary():
    """Targets beyond the box's upper friction end: the answer sits on the
    sliding-friction bound."""
    targets = (
        Target("lift", "angle", lift((1.2, 0.1))["lift.angle"]),
        Target("lift", "density", lift((1.2, 0.1))["lift.density"]),
    )
    opt = Optimizer(
        [0.1, 0.02],
        [0.9, 0.3],
        {"strategy": "response_ei", "max_evaluations": 16},
        seed=3,
        objective=ResponseObjective(targets),
    )
    while opt.completed_evaluations() < 16:
        proposal = opt.ask(1)[0]
        opt.tell(proposal.id, responses={k: [v] for k, v in lift(proposal.x).items()})
    best = opt.best()
    assert best.x[0] == pytest.approx(0.9, abs=0.008) and best.on_bounds[0] == (0, "upper")


@pytest.mark.parametrize("strategy", ["response_ei", "dycors"])
@pytest.mark.slow
def test_early_termination_does_not_stall_in_one_region(strategy):
    """A stopped run's responses enter the models: no long run of stops in one neighbourhood.

    The calibration is simulated in-process on the closed form with 1 %
    seeded noise: each evaluation's estimate is its final responses (as the
    analytic engine reports them half way), and early termination (default
    factors) stops it when the optimizer's rule says so. Before responses
    were data, stopped runs never reached the surrogate and the search
    proposed the stopped region again and again.
    """
    rng = np.random.default_rng(1)
    opt = optimizer(strategy=strategy, max_evaluations=40)
    in_a_row, longest, last_stop = 0, 0, None
    while proposal := opt.ask(1):
        p = proposal[0]
        responses = {k: v * (1 + 0.01 * rng.standard_normal()) for k, v in lift(p.x).items()}
        estimate = float(objective_values(TARGETS, responses))
        if opt.best_observed is not None and opt.early_termination(p.id, estimate).stop:
            opt.tell(
                p.id,
                status="terminated",
                partial={k: {"values": [v], "final": True} for k, v in responses.items()},
            )
            near = (
                last_stop is not None
                and np.linalg.norm((np.array(p.x) - last_stop) / [0.8, 0.28]) < 0.1
            )
            in_a_row = in_a_row + 1 if near else 1
            longest, last_stop = max(longest, in_a_row), np.array(p.x)
        else:
            opt.tell(p.id, responses={k: [v] for k, v in responses.items()})
            in_a_row, last_stop = 0, None
    assert longest <= 3
    noise_level = 2 * 0.01**2  # eq. 3.3 of 1 % noise in two responses
    assert objective_values(TARGETS, lift(opt.best().x)) < noise_level


@pytest.mark.slow
def test_state_with_objective_and_responses_resumes_to_the_same_proposal():
    opt = optimizer()
    for proposal in opt.ask(8):
        opt.tell(proposal.id, responses={k: [v] for k, v in lift(proposal.x).items()})
    copy = Optimizer.from_json(opt.to_json(), opt.objective)
    assert copy.ask(1)[0].x == opt.ask(1)[0].x


def test_response_strategies_need_the_targets():
    with pytest.raises(ValueError, match="needs the targets"):
        Optimizer([0.1, 0.02], [0.9, 0.3], {"strategy": "response_ei"})


@pytest.mark.slow
def test_confirmation_resimulates_the_best_point_once_and_keeps_it_the_answer():
    rng = np.random.default_rng(1)
    opt = optimizer(max_evaluations=12, confirm_replicates=3)
    assert opt.confirm() == []  # nothing to confirm yet
    while proposals := opt.ask(1):
        opt.tell(
            proposals[0].id,
            responses={
                k: [v * (1 + 0.01 * rng.standard_normal())] for k, v in lift(proposals[0].x).items()
            },
        )
    best = opt.best()
    confirmations = opt.confirm()
    assert len(confirmations) == 3 and opt.confirm() == []
    assert all(p.x == pytest.approx(best.x) for p in confirmations)
    assert not opt.early_termination(confirmations[0].id, 1e9).stop
    told = []
    for proposal in confirmations:
        told.append(
            {k: v * (1 + 0.01 * rng.standard_normal()) for k, v in lift(proposal.x).items()}
        )
        opt.tell(proposal.id, responses={k: [v] for k, v in told[-1].items()})
    summary = opt.confirmation()
    assert summary.confirms == best.id and summary.pending == 0 and summary.failed == 0
    angles = [t["lift.angle"] for t in told]
    angle = summary.responses["lift.angle"]
    assert (angle.mean, angle.sd, angle.count) == pytest.approx(
        (np.mean(angles), np.std(angles, ddof=1), 3)
    )
    assert opt.best().id == best.id
    assert Optimizer.from_json(opt.to_json(), opt.objective).confirmation() == summary


def test_the_search_stops_once_the_answer_is_known():
    """On the lift with small noise the best point meets both spreads long before 40
    evaluations; the search then stops and says why; switched off, it would go on."""
    rng = np.random.default_rng(11)
    opt = optimizer(kriging_restarts=1)
    while opt.stop_reason(0.0) is None:
        (proposal,) = opt.ask(1)
        noisy = {k: [v * (1 + 0.002 * rng.standard_normal())] for k, v in lift(proposal.x).items()}
        opt.tell(proposal.id, responses=noisy)
    reason = opt.stop_reason(0.0)
    assert reason.startswith("answer known: the best point's predicted responses meet every")
    assert opt.completed_evaluations() < 40
    assert all(abs(lift(opt.best().x)[t.key] - t.value) <= t.spread for t in TARGETS)
    opt.settings = dataclasses.replace(opt.settings, stop_when_known=False)
    assert opt.stop_reason(0.0) is None
