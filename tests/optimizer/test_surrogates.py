import numpy as np
import pytest
from scipy.interpolate import RBFInterpolator

from demcal.optimizer.surrogates.base import cap_at_median, merge_duplicates
from demcal.optimizer.surrogates.cubic_rbf import CubicRBF
from demcal.optimizer.surrogates.kriging import KrigingSurrogate
from demcal.optimizer.surrogates.smt_rbf import SMTRadialBasis


def smooth(x):
    return np.sin(3 * x[:, 0]) + (x[:, 1] - 0.3) ** 2


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    x = rng.random((25, 2))
    return x, smooth(x)


def test_cubic_rbf_matches_scipy_rbf_interpolator(data):
    x, y = data
    y = cap_at_median(y)  # capping is idempotent, so both models see the same values
    ours = CubicRBF(smoothing=0.0).fit(x, y)
    reference = RBFInterpolator(x, y, kernel="cubic", degree=1)
    probe = np.random.default_rng(1).random((50, 2))
    assert np.allclose(ours.predict(probe), reference(probe), atol=1e-8)


@pytest.mark.parametrize("model", [CubicRBF(), KrigingSurrogate(restarts=2), SMTRadialBasis()])
def test_each_surrogate_fits_and_predicts_reasonably(data, model):
    x, y = data
    model.fit(x, y)
    low = y <= np.median(y)
    assert np.max(np.abs(model.predict(x[low]) - y[low])) < 0.1


def test_kriging_predicts_a_standard_deviation(data):
    x, y = data
    model = KrigingSurrogate(restarts=2).fit(x, y)
    far = model.predict_std(np.array([[2.0, 2.0]]))
    assert far.shape == (1,) and far[0] > 0


def test_exact_duplicates_are_merged_and_averaged():
    x = np.array([[0.1, 0.1], [0.1, 0.1], [0.9, 0.2]])
    merged_x, merged_y, merged_variance = merge_duplicates(
        x, np.array([1.0, 3.0, 5.0]), np.zeros(3), 1e-9
    )
    assert merged_x.tolist() == [[0.1, 0.1], [0.9, 0.2]]
    assert merged_y.tolist() == [2.0, 5.0]


def test_duplicate_and_near_duplicate_points_give_a_sane_model(data):
    x, y = data
    x = np.vstack([x, x[:3], x[:3] + 1e-12])
    y = np.concatenate([y, y[:3], y[:3]])
    probe = np.random.default_rng(1).random((50, 2))
    clean = CubicRBF().fit(x[:25], y[:25]).predict(probe)
    assert np.allclose(CubicRBF().fit(x, y).predict(probe), clean, atol=1e-6)


def test_constant_data_give_a_constant_model():
    x = np.random.default_rng(2).random((8, 2))
    for model in (CubicRBF(), KrigingSurrogate(restarts=2)):
        model.fit(x, np.full(8, 4.0))
        assert np.allclose(model.predict(np.array([[0.3, 0.7]])), 4.0)


def test_outliers_are_capped_at_the_median():
    assert cap_at_median(np.array([1.0, 2.0, 3.0, 1e9])).tolist() == [1.0, 2.0, 2.5, 2.5]
    rng = np.random.default_rng(3)
    x = rng.random((20, 2))
    y = smooth(x)
    y[0] = 1e12  # a penalised value
    prediction = CubicRBF().fit(x, y).predict(rng.random((30, 2)))
    assert np.all(np.abs(prediction) < 10)


def test_noisy_data_get_smoothed_and_noise_free_data_interpolated(data):
    x, y = data
    assert CubicRBF().fit(x, y).chosen_smoothing == 0.0
    rng = np.random.default_rng(4)
    x = rng.random((40, 2))
    noisy = 0.05 * x[:, 0] + rng.normal(0, 0.5, 40)
    assert CubicRBF().fit(x, noisy).chosen_smoothing > 0.0


def test_replicate_variance_smooths_the_fit(data):
    x, y = data
    variance = np.full(len(y), 0.5)
    model = CubicRBF(smoothing=0.0).fit(x, y, variance)
    low = y < np.median(y)
    assert np.max(np.abs(model.predict(x[low]) - y[low])) > 1e-6
