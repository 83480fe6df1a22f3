import dataclasses

import numpy as np
import pytest

from demcal.optimizer import RunProgress, early_termination_decision, estimate_heading
from demcal.optimizer.early_termination import estimate_noise, termination_factor
from demcal.optimizer.evaluation import Evaluation, ObservedResponse
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.optimizer.responses import ESTIMATE_RELATIVE_SD
from demcal.results.records import Status


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


def test_the_weighed_rule_asks_more_the_less_a_stop_saves():
    """Limit 10 x 0.02 = 0.2. Half done, a stop saves half: the estimate must pass 0.4."""
    half = RunProgress(0.5)
    assert early_termination_decision(0.02, 0.3, 0.1, rule="eq_3_4", run=half).stop
    assert not early_termination_decision(0.02, 0.3, 0.1, run=half).stop
    decision = early_termination_decision(0.02, 0.41, 0.1, run=half)
    assert decision.stop and decision.limit == pytest.approx(0.4)
    assert "0.41 > 10 x best 0.02 / 0.50 left" in decision.reason
    # the first of five replicates done: 1.25 x the limit
    assert early_termination_decision(0.02, 0.26, 0.1, run=RunProgress(0.2)).stop
    # without where the run stands, eq. 3.4 alone
    assert early_termination_decision(0.02, 0.3, 0.1).stop


def test_a_run_in_its_last_stretch_is_finished_whatever_the_limit():
    decision = early_termination_decision(0.02, 100.0, 0.9, run=RunProgress(0.93))
    assert not decision.stop and "last stretch (93% done)" in decision.reason
    assert early_termination_decision(0.02, 100.0, 0.9, run=RunProgress(0.93), rule="eq_3_4").stop
    assert early_termination_decision(0.02, 100.0, 0.9, run=RunProgress(0.85)).stop
    assert not early_termination_decision(
        0.02, 100.0, 0.9, run=RunProgress(0.85), last_stretch=0.8
    ).stop


def test_a_falling_estimate_is_judged_by_where_it_heads_a_rising_one_by_where_it_is():
    falling = estimate_heading([(0.1, 0.5), (0.2, 0.4), (0.3, 0.3)])
    assert falling == pytest.approx(-0.4)  # the line at done = 1; the rule floors it at 0
    spared = early_termination_decision(0.02, 0.3, 0.1, run=RunProgress(0.3, falling))
    assert not spared.stop and "heading to 0" in spared.reason
    rising = estimate_heading([(0.1, 0.1), (0.2, 0.15), (0.3, 0.2)])
    assert rising == pytest.approx(0.55)
    assert not early_termination_decision(0.02, 0.2, 0.1, run=RunProgress(0.3, rising)).stop


def test_no_heading_from_too_few_or_too_close_estimates():
    assert estimate_heading([(0.1, 0.5), (0.3, 0.3)]) is None
    assert estimate_heading([(0.30, 0.5), (0.31, 0.4), (0.32, 0.3)]) is None
    assert estimate_heading(
        [(0.1, 9.0), (0.2, 0.5), (0.3, 0.5), (0.4, 0.5), (0.5, 0.5), (0.6, 0.5)]
    ) == pytest.approx(0.5)


def test_a_running_estimate_is_judged_against_the_noise_it_carries():
    """Five replicates per point, 0.1 sd each on a target of 1 (relative form): an early
    estimate at the target carries that and an early estimate's own 5 %, (0.1^2 + 0.05^2)
    on average, a final one the 0.1 alone; over only the responses it estimates."""
    rng = np.random.default_rng(3)
    targets = (Target("s", "a", 1.0), Target("s", "b", 2.0))
    objective = ResponseObjective(targets, "relative")
    records = [
        Evaluation(
            i,
            (i / 4.0,),
            False,
            Status.OK,
            responses={
                "s.a": ObservedResponse(tuple(1.0 + 0.1 * rng.standard_normal(5))),
                "s.b": ObservedResponse((2.0,) * 5),
            },
        )
        for i in range(40)
    ]
    early = ESTIMATE_RELATIVE_SD**2
    a = ["s.a"]
    assert estimate_noise(records, objective, a, a) == pytest.approx(0.01 + early, rel=0.15)
    assert estimate_noise(records, objective, a) == pytest.approx(0.01, rel=0.15)  # final
    assert estimate_noise(records, objective, (), ["s.a", "s.b"]) == pytest.approx(
        0.01 + 2 * early, rel=0.15
    )
    assert estimate_noise(records, objective, ["s.b"], ["s.b"]) == pytest.approx(early)
    once = [
        dataclasses.replace(
            r, responses={k: ObservedResponse(v.values[:1]) for k, v in r.responses.items()}
        )
        for r in records
    ]
    assert estimate_noise(once, objective, a, a) == pytest.approx(early)
    assert estimate_noise(once, objective, a) == 0.0
