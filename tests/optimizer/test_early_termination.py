import pytest

from demcal.optimizer import early_termination_decision
from demcal.optimizer.early_termination import termination_factor


@pytest.mark.parametrize(
    "progress, factor",
    [(0.0, 10.0), (0.49, 10.0), (0.5, 5.0), (0.74, 5.0), (0.75, 2.5), (1.0, 2.5), (1.7, 2.5)],
)
def test_thesis_pattern_10_5_2_5(progress, factor):
    assert termination_factor(min(progress, 1.0)) == factor


def test_stop_only_above_c_times_best():
    # best 0.02, first half: c = 10, limit 0.2
    assert early_termination_decision(0.02, 0.21, 0.1).stop
    assert not early_termination_decision(0.02, 0.2, 0.1).stop
    # third quarter: c = 5, limit 0.1
    decision = early_termination_decision(0.02, 0.11, 0.6)
    assert decision.stop and decision.factor == 5.0
    # last quarter: c = 2.5, limit 0.05
    assert early_termination_decision(0.02, 0.051, 0.9).stop
    assert not early_termination_decision(0.02, 0.049, 0.9).stop


def test_never_during_initial_design_or_when_disabled_or_without_best():
    assert not early_termination_decision(0.01, 100.0, 0.9, in_initial_design=True).stop
    assert not early_termination_decision(0.01, 100.0, 0.9, enabled=False).stop
    assert not early_termination_decision(None, 100.0, 0.9).stop


def test_configurable_pattern():
    decision = early_termination_decision(
        1.0, 3.5, 0.5, thresholds=(4.0, 3.0), progress_boundaries=(0.4,)
    )
    assert decision.stop and decision.factor == 3.0
