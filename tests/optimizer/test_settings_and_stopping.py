import pytest

from demcal.optimizer import OptimizerSettings
from demcal.optimizer.stopping import stop_reason


def test_defaults_follow_the_thesis():
    s = OptimizerSettings.from_dict({})
    assert (s.candidates, s.sigma_max, s.sigma_min, s.success_tolerance) == (200, 0.2, 0.2 / 64, 3)
    assert s.weights == (0.3, 0.5, 0.8, 0.95)
    assert s.failures_to_halve(2) == 4
    assert s.early_termination.thresholds == (10.0, 5.0, 2.5)


@pytest.mark.parametrize(
    "values, message",
    [
        ({"strategy": "foo"}, "optimizer.strategy: 'foo' is not one of dycors, kriging_ei"),
        ({"sigma_max": 2.0}, "optimizer.sigma_max: 2.0 is out of range"),
        ({"colour": 1}, "optimizer.colour: unknown field; allowed here: calm_proposals"),
        (
            {"max_evaluation": 1},
            "optimizer.max_evaluation: unknown field; did you mean max_evaluations",
        ),
        ({"max_evaluations": 0}, "optimizer.max_evaluations: 0 is out of range"),
        ({"early_termination": {"thresholds": [10, 5]}}, "progress_boundaries"),
        ({"strategy": "kriging_ei", "surrogate": "cubic_rbf"}, "optimizer.surrogate: 'cubic_rbf'"),
    ],
)
def test_bad_values_name_key_value_and_range(values, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        OptimizerSettings.from_dict(values)


def test_round_trip_through_a_dict():
    s = OptimizerSettings.from_dict(
        {"max_evaluations": 30, "early_termination": {"enabled": False}}
    )
    assert OptimizerSettings.from_dict(s.to_dict()) == s


def reason(**changes):
    arguments = dict(
        evaluations=5,
        max_evaluations=10,
        elapsed_seconds=1.0,
        max_seconds=None,
        best_value=1.0,
        target_objective=None,
        evaluations_without_improvement=0,
        no_improvement_evaluations=None,
        step_collapsed=False,
    )
    arguments.update(changes)
    return stop_reason(**arguments)


def test_each_stopping_rule():
    assert reason() is None
    assert reason(evaluations=10).startswith("evaluation budget")
    assert reason(max_seconds=1.0).startswith("wall-clock")
    assert reason(target_objective=1.0).startswith("target objective")
    assert reason(evaluations_without_improvement=3, no_improvement_evaluations=3).startswith(
        "no improvement"
    )
    assert reason(step_collapsed=True).startswith("trust region")
