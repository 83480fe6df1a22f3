"""Neighbouring materials as inputs of the response models (issue 38, item 7): the model of
:mod:`demcal.optimizer.surrogates.material` predicts a material it has no run of from its
neighbours' runs, where a model that ignores the material cannot."""

from __future__ import annotations

import numpy as np
import pytest

from demcal.optimizer.surrogates.kriging import KrigingSurrogate
from demcal.optimizer.surrogates.material import MaterialKriging, material_inputs


def bulk_density(x: np.ndarray, particle_density: float) -> np.ndarray:
    """A bulk density that loosens with both frictions and scales with the particle density."""
    return particle_density * (0.64 - 0.05 * x[:, 0] - 0.08 * np.sqrt(x[:, 1]))


def test_the_material_inputs_are_scaled_to_a_unit_and_constant_ones_left_out():
    offsets = np.array([[0.0, -0.1, 3.0], [-200.0, -0.1, 3.0], [100.0, -0.1, 0.0]])
    assert material_inputs(offsets).tolist() == [200.0, 0.0, 3.0]
    assert material_inputs(np.zeros((0, 2))).tolist() == [0.0, 0.0]


def test_two_neighbouring_densities_predict_a_third_with_no_run_of_its_own():
    rng = np.random.default_rng(4)
    x = rng.random((40, 2))
    densities = np.repeat([2400.0, 2500.0], 20)
    y = np.concatenate([bulk_density(x[:20], 2400.0), bulk_density(x[20:], 2500.0)])
    offsets = (densities - 2600.0)[:, None]
    model = MaterialKriging(restarts=1, seed=0).fit(x, y, np.zeros(len(y)), offsets)
    grid = rng.random((200, 2))
    truth = bulk_density(grid, 2600.0)
    error = np.sqrt(np.mean((model.predict(grid) - truth) ** 2))
    blind = KrigingSurrogate(restarts=1, seed=0).fit(x, y, np.zeros(len(y)))
    blind_error = np.sqrt(np.mean((blind.predict(grid) - truth) ** 2))
    assert error < 10.0  # kg/m^3; the material is about 56 kg/m^3 above the nearer one
    assert blind_error > 5.0 * error
    assert np.all(model.predict_std(grid) >= 0.0)


def test_one_run_of_its_own_teaches_the_shift_from_a_single_neighbour():
    rng = np.random.default_rng(5)
    neighbours = rng.random((20, 2))
    own = np.array([[0.5, 0.5]])
    x = np.vstack([own, neighbours])
    y = np.concatenate([bulk_density(own, 2600.0), bulk_density(neighbours, 2500.0)])
    offsets = np.vstack([[[0.0]], np.full((20, 1), -100.0)])
    model = MaterialKriging(restarts=1, seed=0).fit(x, y, np.zeros(len(y)), offsets)
    grid = rng.random((200, 2))
    error = np.sqrt(np.mean((model.predict(grid) - bulk_density(grid, 2600.0)) ** 2))
    assert error < 10.0  # the neighbour alone is 50-60 kg/m^3 off


def test_before_a_run_of_its_own_a_single_neighbour_stands_for_the_material():
    rng = np.random.default_rng(6)
    x = rng.random((12, 2))
    y = bulk_density(x, 2500.0)
    model = MaterialKriging(restarts=1, seed=0).fit(x, y, np.zeros(12), np.full((12, 1), -100.0))
    plain = KrigingSurrogate(restarts=1, seed=0).fit(x, y, np.zeros(12))
    grid = rng.random((20, 2))
    assert model.predict(grid) == pytest.approx(plain.predict(grid))
