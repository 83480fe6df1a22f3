import numpy as np
import pytest

from demcal.optimizer import Optimizer


def sphere(x):
    return float(np.sum((np.asarray(x) - 0.3) ** 2))


def run(optimizer, evaluations):
    for _ in range(evaluations):
        (proposal,) = optimizer.ask()
        optimizer.tell(proposal.id, sphere(proposal.x))


def test_proposals_respect_bounds_and_ids_increase():
    optimizer = Optimizer([-1, 0], [1, 2], {"max_evaluations": 20}, seed=1)
    ids = []
    for _ in range(20):
        (proposal,) = optimizer.ask()
        assert -1 <= proposal.x[0] <= 1 and 0 <= proposal.x[1] <= 2
        ids.append(proposal.id)
        optimizer.tell(proposal.id, sphere(proposal.x))
    assert ids == sorted(set(ids))
    assert optimizer.ask() == []
    assert optimizer.stop_reason(0.0).startswith("evaluation budget")


def test_finds_the_minimum_of_a_sphere():
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 30}, seed=2)
    run(optimizer, 30)
    assert optimizer.best().value < 1e-4


def test_initial_points_are_proposed_first():
    optimizer = Optimizer([0, 0], [1, 1], {}, seed=3, initial_points=[[0.25, 0.75]])
    assert optimizer.ask()[0].x == [0.25, 0.75]


def test_workers_enlarge_the_initial_design():
    assert Optimizer([0, 0], [1, 1], {}, seed=0, workers=4).initial_size == 8


def test_pending_points_are_never_duplicated():
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 60}, seed=4, workers=4)
    run(optimizer, 10)
    pending = optimizer.ask(4)
    for _ in range(8):
        done = pending.pop(0)
        optimizer.tell(done.id, sphere(done.x))
        pending += optimizer.ask(1)
        points = np.array([p.x for p in pending])
        gaps = np.linalg.norm(points[:, None] - points[None], axis=2) + np.eye(len(points))
        assert gaps.min() > 1e-6


def test_failed_points_are_excluded_and_terminated_kept_out_of_the_data():
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 40}, seed=5)
    run(optimizer, 8)
    (failed,) = optimizer.ask()
    optimizer.tell(failed.id, status="failed")
    (stopped,) = optimizer.ask()
    optimizer.tell(stopped.id, status="terminated")
    optimizer.tell(optimizer.ask()[0].id, float("nan"))  # non-finite: recorded as failed
    for _ in range(15):
        (proposal,) = optimizer.ask()
        assert np.linalg.norm(np.subtract(proposal.x, failed.x)) > 0.02
        assert np.linalg.norm(np.subtract(proposal.x, stopped.x)) > 1e-5
        optimizer.tell(proposal.id, sphere(proposal.x))
    optimizer.best()  # refits the surrogate
    assert optimizer._surrogate_version == 23  # 8 + 15 values, no failed or terminated
    assert optimizer.completed_evaluations() == 26


def test_replicates_give_mean_and_spread():
    optimizer = Optimizer([0], [1], {}, seed=6)
    (proposal,) = optimizer.ask()
    optimizer.tell(proposal.id, replicates=[1.0, 2.0, 3.0])
    record = optimizer.records[0]
    assert record.value == 2.0
    assert record.variance == pytest.approx(1.0 / 3)


def test_tell_rejects_unknown_or_repeated_ids():
    optimizer = Optimizer([0], [1], {}, seed=7)
    (proposal,) = optimizer.ask()
    optimizer.tell(proposal.id, 1.0)
    with pytest.raises(ValueError):
        optimizer.tell(proposal.id, 1.0)
    with pytest.raises(ValueError):
        optimizer.tell(99, 1.0)


def test_best_is_the_surrogate_best_not_the_luckiest_sample():
    rng = np.random.default_rng(8)
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 60}, seed=8)
    for _ in range(40):
        (proposal,) = optimizer.ask()
        optimizer.tell(proposal.id, sphere(proposal.x) + rng.normal(0, 0.02))
    best = optimizer.best()
    assert best.predicted != best.value
    assert best.value >= min(r.value for r in optimizer.records if r.finished)


@pytest.mark.parametrize("strategy", ["dycors", "kriging_ei"])
def test_state_round_trip_gives_the_same_next_proposal(strategy):
    settings = {"max_evaluations": 30, "strategy": strategy, "kriging_restarts": 1}
    optimizer = Optimizer([0, 0, 0], [1, 2, 3], settings, seed=9, workers=2)
    run(optimizer, 10)
    optimizer.ask(1)  # leave one pending
    restored = Optimizer.from_json(optimizer.to_json())
    assert restored.ask(2) == optimizer.ask(2)
    assert restored.to_json() == optimizer.to_json()


def test_early_termination_uses_progress_and_design_phase():
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 25}, seed=10)
    (first,) = optimizer.ask()
    optimizer.tell(first.id, 1.0)
    (design_point,) = optimizer.ask()
    assert not optimizer.early_termination(design_point.id, 1e9).stop
    optimizer.tell(design_point.id, 1.0)
    run(optimizer, 3)
    (adaptive,) = optimizer.ask()
    assert not adaptive.in_initial_design
    decision = optimizer.early_termination(adaptive.id, 11.0 * optimizer.best_observed)
    assert decision.stop and decision.factor == 10.0


@pytest.mark.parametrize("stop_on_collapse", [True, False])
def test_collapsed_step_size_stops_only_when_asked(stop_on_collapse):
    optimizer = Optimizer([0, 0], [1, 1], {"stop_on_step_collapse": stop_on_collapse}, seed=11)
    optimizer.step.collapsed = True
    reason = optimizer.stop_reason(0.0)
    assert (reason is not None and reason.startswith("trust region")) == stop_on_collapse


def test_reopened_failure_is_pending_again_and_can_be_told():
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 3}, seed=4)
    proposals = optimizer.ask(3)
    optimizer.tell(proposals[0].id, status="failed")
    for p in proposals[1:]:
        optimizer.tell(p.id, sphere(p.x))
    assert optimizer.stop_reason(0.0).startswith("evaluation budget")
    optimizer.reopen(proposals[0].id)
    assert optimizer.pending() == [proposals[0].id]
    assert optimizer.stop_reason(0.0) is None
    assert optimizer.ask() == []  # the budget is held by the reopened point
    optimizer.tell(proposals[0].id, 0.5)
    assert optimizer.completed_evaluations() == 3
    fresh = Optimizer([0], [1], {}, seed=1)
    with pytest.raises(ValueError, match="still pending"):
        fresh.reopen(fresh.ask()[0].id)


def test_four_workers_start_the_adaptive_phase_with_a_surrogate():
    """d = 2, P = 4: design of 2d + P = 8; when the last design point is running, 2d + 1
    = 5 are finished."""
    optimizer = Optimizer([0, 0], [1, 1], {"max_evaluations": 20}, seed=3, workers=4)
    running = [p.id for p in optimizer.ask(4)]
    for value in (4.0, 3.0, 2.0, 1.0):
        optimizer.tell(running.pop(0), value)
        running += [p.id for p in optimizer.ask()]
    assert running == [4, 5, 6, 7] and not optimizer.design_queue
    optimizer.tell(running.pop(0), 0.5)
    assert optimizer.completed_evaluations() == 5
    assert optimizer._fitted_surrogate() is not None
    assert optimizer.ask()[0].in_initial_design is False
