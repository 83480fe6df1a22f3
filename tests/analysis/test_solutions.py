"""The solution space and identifiability verdicts on response models of known responses."""

import numpy as np
import pytest

from demcal.analysis.solutions import (
    identifiability,
    largest_total_index,
    sample_solutions,
    sensitivity_indices,
    simulation_noise_sd,
)
from demcal.optimizer.membership import band_sd, membership_probability, tolerance_sd
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.optimizer.responses import ResponsePredictor
from demcal.optimizer.surrogates.cubic_rbf import ResponseRBF

NAMES, UNITS = ["sliding_friction_pp", "sliding_friction_pw"], ["-", "-"]
LOWER, UPPER = np.array([0.2, 0.2]), np.array([0.9, 0.9])


def predictor_of(responses: dict, targets: tuple[Target, ...]) -> ResponsePredictor:
    """Cubic RBF models of closed-form responses of the unit box, fitted on a
    seeded 40-point sample."""
    x = np.random.default_rng(3).random((40, 2))
    models = {key: ResponseRBF().fit(x, f(x), np.zeros(len(x))) for key, f in responses.items()}
    return ResponsePredictor(models, ResponseObjective(targets))


def analyse(responses, targets):
    predictor = predictor_of(responses, targets)
    noise = {key: 0.0 for key in responses}
    solutions = sample_solutions(predictor, 2, noise, k=2.0, samples=4096, seed=1)
    indices = sensitivity_indices(predictor, NAMES, base_samples=256, seed=1)
    return (
        solutions,
        indices,
        identifiability(solutions, NAMES, UNITS, LOWER, UPPER, largest_total_index(indices)),
    )


def test_a_response_of_one_parameter_pins_it_and_leaves_the_other_free():
    """Mass flow = 10 x0 with a target of 5 ± 0.2: x0 within 0.46-0.54 of the unit box
    (pinned), x1 anywhere."""
    target = Target("calibration_device", "mass_flow", 5.0, spread=0.2)
    solutions, indices, (pp, pw) = analyse({target.key: lambda x: 10 * x[:, 0]}, (target,))
    assert pp.verdict == "pinned" and pw.verdict == "not identified"
    assert 0.2 + 0.7 * 0.44 < pp.low < pp.high < 0.2 + 0.7 * 0.56
    assert pw.share > 0.9
    assert (
        "no targeted response is sensitive to it" in pw.sentence
        and "sliding_friction_pw" in pw.sentence
    )
    by_name = {row["parameter"]: row for row in indices}
    assert (
        by_name["sliding_friction_pp"]["ST"] > 0.9 and by_name["sliding_friction_pw"]["ST"] < 0.05
    )
    assert np.all(np.abs(solutions.means[target.key] - 5.0) <= 2 * 0.2 + 1e-9)


def test_a_trade_off_between_two_parameters_is_named_as_such():
    """Angle = 20 (x0 + x1) with a target of 20 ± 0.5: a line through the box, neither
    parameter identified."""
    target = Target("cylinder_lift", "angle_of_repose", 20.0, spread=0.5)
    _, _, verdicts = analyse({target.key: lambda x: 20 * (x[:, 0] + x[:, 1])}, (target,))
    assert [v.verdict for v in verdicts] == ["not identified", "not identified"]
    assert all("trades off against other parameters" in v.sentence for v in verdicts)


def test_a_target_out_of_reach_gives_no_verdict_instead_of_a_range():
    target = Target("cylinder_lift", "angle_of_repose", 80.0, spread=0.5)
    solutions, _, verdicts = analyse({target.key: lambda x: 20 * (x[:, 0] + x[:, 1])}, (target,))
    assert len(solutions.points_unit) == 0
    assert all(v.verdict == "no solutions" and "only 0 of 4096" in v.sentence for v in verdicts)


def test_the_band_is_the_targets_standard_error_and_discrepancy_not_the_simulation_noise():
    """Spread 3 of single tests: band sd 3 whatever the simulations' scatter (4); the mean of
    4 tests: standard error 1.5, with a discrepancy of 2: 2.5; the model's sd adds to it."""
    single = Target("s", "r", 10.0, spread=3.0)
    assert tolerance_sd(single, 4.0, np.array([0.0, 4.0])) == pytest.approx([3.0, 5.0])
    mean_of_four = Target("s", "r", 10.0, spread=3.0, tests=4, discrepancy=2.0)
    assert band_sd(mean_of_four, 4.0) == pytest.approx(2.5)
    means, stds = {"s.r": np.array([15.9, 16.1])}, {"s.r": np.zeros(2)}
    sure = membership_probability((single,), means, stds, {"s.r": 4.0}, k=2.0)
    assert sure.tolist() == [1.0, 0.0]


def test_a_target_without_a_spread_is_judged_by_the_simulation_noise():
    unmeasured = Target("s", "r", 10.0, discrepancy=3.0)
    assert band_sd(unmeasured, 4.0) == pytest.approx(5.0)


def test_membership_is_the_chance_that_the_noise_free_response_lies_in_the_band():
    """Target 10, band ±2 x 5 = ±10: a prediction of 20 ± 5 on the band's edge is in with
    probability 1/2; 10 ± 5, centred, with 2 Phi(2) - 1; two responses multiply."""
    a, b = Target("s", "a", 10.0, spread=5.0), Target("s", "b", 10.0, spread=5.0)
    means = {"s.a": np.array([20.0, 10.0]), "s.b": np.array([10.0, 10.0])}
    stds = {"s.a": np.array([5.0, 5.0]), "s.b": np.array([5.0, 5.0])}
    noise = {"s.a": 4.0, "s.b": 4.0}
    centred = 2 * 0.9772498680518208 - 1
    p = membership_probability((a, b), means, stds, noise, k=2.0)
    assert p == pytest.approx([0.5 * centred, centred**2], rel=1e-3)


def test_the_noise_is_the_scatter_of_simulations_about_the_model():
    target = Target("s", "r", 1.0)
    predictor = predictor_of({target.key: lambda x: x[:, 0]}, (target,))
    x = np.array([[0.1, 0.1], [0.5, 0.5], [0.9, 0.2]])
    observed = {target.key: (x, x[:, 0] + np.array([0.03, -0.03, 0.03]))}
    assert simulation_noise_sd(predictor, observed)[target.key] == pytest.approx(0.03, abs=2e-3)


class HalfKnown:
    """A response model that predicts the target everywhere, sure of it only where x0 < 0.5."""

    noise_sd = 0.0

    def predict(self, x):
        return np.full(len(np.atleast_2d(x)), 5.0)

    def predict_std(self, x):
        return np.where(np.atleast_2d(x)[:, 0] < 0.5, 0.0, 10.0)


def test_a_span_the_unexplored_part_could_widen_is_not_established():
    target = Target("calibration_device", "mass_flow", 5.0, spread=1.0)
    predictor = ResponsePredictor({target.key: HalfKnown()}, ResponseObjective((target,)))
    solutions = sample_solutions(predictor, 2, {target.key: 0.0}, samples=4096, seed=2)
    assert len(solutions.points_unit) == 4096  # nothing can be ruled out
    decided = ~solutions.unsure
    assert np.array_equal(decided, solutions.points_unit[:, 0] < 0.5)
    assert solutions.unsure_share == pytest.approx(0.5, abs=0.01)
    pp, pw = identifiability(solutions, NAMES, UNITS, LOWER, UPPER, explore_command="EXPLORE")
    assert (
        pp.verdict == "not established"
        and pp.high < 0.2 + 0.7 * 0.5 < 0.2 + 0.7 * 0.99 < pp.possible_high
    )
    assert "50 % of the set lies where no simulation has been; `EXPLORE`" in pp.sentence
    assert pw.verdict == "not identified"  # a span of the whole box cannot narrow


class Unsure:
    """A response model with no evidence anywhere: the target is possible, never likely."""

    noise_sd = 0.0

    def predict(self, x):
        return np.full(len(np.atleast_2d(x)), 0.0)

    def predict_std(self, x):
        return np.full(len(np.atleast_2d(x)), 5.0)


def test_with_nothing_likely_yet_the_verdict_is_not_established_not_no_solutions():
    target = Target("calibration_device", "mass_flow", 5.0, spread=1.0)
    predictor = ResponsePredictor({target.key: Unsure()}, ResponseObjective((target,)))
    solutions = sample_solutions(predictor, 2, {target.key: 0.0}, samples=1024, seed=2)
    assert len(solutions.points_unit) == 1024 and not solutions.likely.any()
    verdicts = identifiability(solutions, NAMES, UNITS, LOWER, UPPER)
    assert all(v.verdict == "not established" for v in verdicts)
    assert all(
        "no parameter set is yet predicted to meet every target" in v.sentence for v in verdicts
    )


class Linear:
    """An exact model of mass flow = 10 x0, sure everywhere."""

    noise_sd = 0.0

    def predict(self, x):
        return 10.0 * np.atleast_2d(x)[:, 0]

    def predict_std(self, x):
        return np.zeros(len(np.atleast_2d(x)))


def test_the_posterior_of_a_linear_response_is_its_gaussian():
    """Target 5 ± 0.2 on 10 x0: x0 ~ N(0.5, 0.02²), 90 % within 0.5 ± 1.645 x 0.02; x1
    keeps its uniform prior; the two are uncorrelated."""
    target = Target("calibration_device", "mass_flow", 5.0, spread=0.2)
    predictor = ResponsePredictor({target.key: Linear()}, ResponseObjective((target,)))
    posterior = sample_solutions(predictor, 2, {target.key: 0.0}, seed=3).posterior
    assert posterior.low == pytest.approx([0.5 - 1.645 * 0.02, 0.05], abs=2e-3)
    assert posterior.high == pytest.approx([0.5 + 1.645 * 0.02, 0.95], abs=2e-3)
    assert abs(posterior.correlation[0, 1]) < 0.02
    assert 2000 < posterior.effective_samples < 65536 / 10
    (pp, _) = identifiability(
        sample_solutions(predictor, 2, {target.key: 0.0}, seed=3), NAMES, UNITS, LOWER, UPPER
    )
    assert pp.posterior_low == pytest.approx(0.2 + 0.7 * (0.5 - 1.645 * 0.02), abs=2e-3)


def test_a_thin_set_is_sampled_again_densely_around_itself():
    """Target 5 ± 0.01 on 10 x0: the set is x0 in 0.498–0.502, 16 of 4096 uniform points;
    sampled again around itself it has over 200, and its ends are found to 1e-4."""
    target = Target("calibration_device", "mass_flow", 5.0, spread=0.01)
    predictor = ResponsePredictor({target.key: Linear()}, ResponseObjective((target,)))
    solutions = sample_solutions(predictor, 2, {target.key: 0.0}, samples=4096, seed=4)
    likely = solutions.points_unit[solutions.likely]
    assert len(likely) > 200 and solutions.sampled == 4096
    assert likely[:, 0].min() == pytest.approx(0.498, abs=1e-4)
    assert likely[:, 0].max() == pytest.approx(0.502, abs=1e-4)
