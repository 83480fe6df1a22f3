"""The advice's math (demcal.analysis.advice): the plane fit, the sets that span the likely
set, and the ranking on a solution set whose most informative test is known."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from demcal.analysis.advice import Shrink, fit_plane, rank, spanning_sets, spans_after
from demcal.analysis.solutions import SolutionSet, posterior_of


def test_a_plane_through_noisy_points_recovers_its_coefficients_and_their_scatter():
    rng = np.random.default_rng(1)
    x = rng.random((40, 2))
    y = 3.0 + 2.0 * x[:, 0] - 1.0 * x[:, 1] + rng.normal(0.0, 0.1, 40)
    fit = fit_plane(x, y)
    assert fit.coefficients == pytest.approx([3.0, 2.0, -1.0], abs=0.1)
    assert fit.residual_sd == pytest.approx(0.1, rel=0.3)
    centre, corner = fit.predict_std(np.array([[0.5, 0.5], [2.0, 2.0]]))
    assert 0.0 < centre < corner  # the band widens away from the data


def test_a_plane_through_d_plus_one_points_is_exact_and_claims_no_scatter():
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    fit = fit_plane(x, np.array([1.0, 3.0, 0.0]))
    assert fit.predict(np.array([[1.0, 1.0]]))[0] == pytest.approx(2.0)
    assert fit.residual_sd == 0.0 and np.all(fit.predict_std(x) == 0.0)
    with pytest.raises(ValueError):
        fit_plane(x[:2], np.array([1.0, 2.0]))


def strip(width: float = 0.05) -> SolutionSet:
    """A solution set on the diagonal strip |x0 + x1 - 1| < width of the unit square: the
    targets pin x0 + x1 and leave the direction along the strip open."""
    points = qmc.Sobol(2, scramble=True, seed=3).random_base2(14)
    inside = np.abs(points.sum(axis=1) - 1.0) < width
    posterior = posterior_of(points, np.where(inside, 0.0, -50.0))
    return SolutionSet(
        points[inside], {}, {}, np.full(int(inside.sum()), 0.97), len(points), 2.0, {}, posterior
    )


def shrink_of(solutions: SolutionSet, response, sets: np.ndarray, spread: float) -> Shrink:
    values = response(sets)
    fit = fit_plane(sets, values)
    lows, highs = spans_after(solutions, "test.response", fit, values, spread)
    before = np.ptp(solutions.points_unit, axis=0)
    return Shrink("test", response.__name__, "-", spread, before, lows, highs, 1.0, 0.0)


def along(x):
    return x[:, 0] - x[:, 1]


def across(x):
    return x[:, 0] + x[:, 1]


def constant(x):
    return np.full(len(x), 2.0)


def test_the_test_that_moves_along_the_open_direction_ranks_first_and_pins_both():
    solutions = strip()
    likely = solutions.points_unit
    picks = spanning_sets(likely, np.empty((0, 2)), 5)
    sets = likely[[i for _, i in picks]]
    shrinks = [shrink_of(solutions, r, sets, 0.02) for r in (constant, across, along)]
    ranked = rank(shrinks, np.array([True, True]))
    assert ranked[0].response == "along"
    best = ranked[0]
    assert np.all(best.after < 0.2 * best.before)  # both spans fall from ~1 to under 0.2
    # every truth stays inside the set it leaves
    assert np.all((best.lows <= sets + 1e-12) & (sets <= best.highs + 1e-12))
    # the two that move nothing the targets have not pinned leave the spans as they were
    for useless in ranked[1:]:
        assert useless.after == pytest.approx(useless.before, abs=0.02)


def test_sets_span_the_likely_set_and_take_the_studys_own_sets_when_nearly_as_good():
    likely = strip().points_unit
    picks = spanning_sets(likely, np.empty((0, 2)), 4)
    sets = likely[[i for _, i in picks]]
    # the strip's two ends are among the first sets: it spans the set
    assert sets[:, 0].min() < 0.05 and sets[:, 0].max() > 0.95
    # a set the study simulated at an end is taken instead of a new one there
    own = np.array([[0.02, 0.98], [0.5, 0.5]])
    picks = spanning_sets(likely, own, 4)
    assert (True, 0) in picks
    # one at the strip's centre is no end: the first set is a new one
    far_off = spanning_sets(likely, np.array([[0.5, 0.5]]), 2)
    assert far_off[0][0] is False
