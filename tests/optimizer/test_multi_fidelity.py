"""Multi-fidelity Kriging of one response (issue 38, item 4): a biased coarse level teaches
the fine prediction; its scale is learnt, its noise kept above the measured floor."""

from __future__ import annotations

import numpy as np
import pytest

from demcal.optimizer.surrogates.kriging import KrigingSurrogate
from demcal.optimizer.surrogates.multi_fidelity import LevelData, MultiFidelityKriging


def fine(x: np.ndarray) -> np.ndarray:
    """A smooth response over the unit square with a ridge, as a calibration response has."""
    return 20.0 + 12.0 * np.tanh(3.0 * x[:, 0] - 1.0) * (0.4 + x[:, 1]) + 3.0 * x[:, 1] ** 2


def coarse(x: np.ndarray) -> np.ndarray:
    """The fine response scaled by 0.8 and shifted by 5: a coarse level's bias."""
    return 0.8 * fine(x) + 5.0


def test_a_biased_coarse_level_teaches_the_fine_prediction():
    rng = np.random.default_rng(4)
    x_fine, x_coarse = rng.random((5, 2)), rng.random((40, 2))
    noise = 0.05
    y_fine = fine(x_fine) + noise * rng.standard_normal(5)
    y_coarse = coarse(x_coarse) + noise * rng.standard_normal(40)
    model = MultiFidelityKriging(seed=1).fit(
        [
            LevelData(x_coarse, y_coarse, np.zeros(40)),
            LevelData(x_fine, y_fine, np.zeros(5)),
        ],
        noise_floor=noise**2,
    )
    test = rng.random((300, 2))
    multi = np.sqrt(np.mean((model.predict(test) - fine(test)) ** 2))
    alone = KrigingSurrogate(seed=1).fit(x_fine, y_fine)
    single = np.sqrt(np.mean((alone.predict(test) - fine(test)) ** 2))
    assert multi < 0.1 * single  # measured: 0.14 against 7.4
    assert model.rho == pytest.approx(1.25, rel=0.1)  # fine = 1.25 coarse - 6.25
    assert model.predict_std(test).shape == (300,) and np.all(model.predict_std(test) >= 0.0)
    assert model.noise_sd >= noise


def test_it_needs_two_levels_with_data():
    one = LevelData(np.zeros((1, 2)), np.zeros(1), np.zeros(1))
    with pytest.raises(ValueError, match="two levels or more"):
        MultiFidelityKriging().fit([one])
    empty = LevelData(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    with pytest.raises(ValueError, match="each with data"):
        MultiFidelityKriging().fit([empty, one])


def test_a_run_is_worth_its_information_per_cpu_second():
    from demcal.optimizer.levels import LevelOutlook, cheap_is_worth_more

    fine = LevelOutlook(1.0, sd=2.0, noise_sd=0.5)
    cheap = LevelOutlook(0.9, sd=2.0, noise_sd=1.0)
    assert fine.information() == pytest.approx(1.0 - 0.5 / np.sqrt(4.25))
    assert cheap.information() == pytest.approx(0.9 * (1.0 - 1.0 / np.sqrt(5.0)))
    assert cheap_is_worth_more([fine], [cheap], cost_ratio=0.1)
    assert not cheap_is_worth_more([fine], [cheap], cost_ratio=0.9)
    assert not cheap_is_worth_more([fine], [None], cost_ratio=0.1)  # it tells nothing
    assert not cheap_is_worth_more([fine], [cheap], cost_ratio=float("nan"))  # cost unknown
    known = LevelOutlook(0.9, sd=0.0, noise_sd=1.0)  # nothing left to learn there
    assert not cheap_is_worth_more([fine], [known], cost_ratio=0.1)


def test_the_outlook_of_the_cheap_level_follows_the_model():
    rng = np.random.default_rng(2)
    x_fine, x_coarse = rng.random((6, 2)), rng.random((30, 2))
    model = MultiFidelityKriging(seed=1).fit(
        [
            LevelData(x_coarse, coarse(x_coarse), np.zeros(30)),
            LevelData(x_fine, fine(x_fine), np.zeros(6)),
        ]
    )
    at_fine, at_cheap = model.outlooks(np.array([0.5, 0.5]))
    assert at_fine.correlation == 1.0
    assert at_fine.sd == pytest.approx(float(model.predict_std(np.array([[0.5, 0.5]]))[0]))
    assert 0.0 <= at_cheap.correlation <= 1.0 and at_cheap.sd >= 0.0
