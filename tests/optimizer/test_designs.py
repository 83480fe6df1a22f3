import numpy as np
import pytest

from demcal.optimizer.designs import (
    default_initial_size,
    initial_design,
    latin_hypercube,
    minimum_pairwise_distance,
    sobol_sequence,
    symmetric_latin_hypercube,
)


def slice_indices(design):
    return np.floor(design * len(design)).astype(int)


@pytest.mark.parametrize("size", [6, 7])
def test_symmetric_latin_hypercube_is_latin_and_symmetric(size):
    design = symmetric_latin_hypercube(size, 3, np.random.default_rng(1))
    for column in slice_indices(design).T:
        assert sorted(column) == list(range(size))
    mirrored = {tuple(np.round(1 - row, 12)) for row in design}
    assert mirrored == {tuple(np.round(row, 12)) for row in design}


def test_latin_hypercube_has_one_point_per_slice():
    design = latin_hypercube(9, 4, np.random.default_rng(2))
    for column in slice_indices(design).T:
        assert sorted(column) == list(range(9))


def test_maximin_selection_is_at_least_as_good_as_one_draw():
    one = initial_design("latin_hypercube", 8, 2, np.random.default_rng(3), tries=1)
    best = initial_design("latin_hypercube", 8, 2, np.random.default_rng(3), tries=50)
    assert minimum_pairwise_distance(best) >= minimum_pairwise_distance(one)


def test_sobol_points_lie_in_the_unit_box():
    design = sobol_sequence(10, 3, np.random.default_rng(4))
    assert design.shape == (10, 3)
    assert np.all((design >= 0) & (design <= 1))


def test_default_size_is_2d_plus_1_plus_one_per_extra_worker():
    assert default_initial_size(2) == 5
    assert default_initial_size(2, workers=4) == 8
    assert default_initial_size(6, workers=1) == 13


def test_user_points_come_first_and_keep_the_size():
    user = np.array([[0.5, 0.5], [0.1, 0.9]])
    design = initial_design(
        "symmetric_latin_hypercube", 7, 2, np.random.default_rng(5), include=user
    )
    assert design.shape == (7, 2)
    assert np.array_equal(design[:2], user)
