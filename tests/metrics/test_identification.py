"""The paper's metric M (Eq. 29) and its recomputation at other thresholds (Eqs. 18-19)."""

import numpy as np
import pytest

from tmopt.metrics import metric_m, metric_m_at_threshold


def test_metric_m_defaults_and_weights():
    # Eq. 29 with weight1 = 1/60, weight2 = 1e10: 60 s and 1e-10 s^-2 count 1 each
    assert metric_m(60.0, 1e-10) == pytest.approx(2.0)
    assert metric_m(30.0, 2e-10, weight1=0.1, weight2=1.0) == pytest.approx(3.0 + 2e-10)
    out = metric_m(np.array([60.0, 120.0]), np.array([0.0, 1e-10]))
    np.testing.assert_allclose(out, [1.0, 3.0])


@pytest.mark.parametrize("kwargs, match", [
    ({"weight1": -1.0}, "weight1"), ({"weight2": float("nan")}, "weight2"),
])
def test_metric_m_rejects_bad_weights(kwargs, match):
    with pytest.raises(ValueError, match=match):
        metric_m(1.0, 1.0, **kwargs)


def test_metric_m_rejects_shape_mismatch():
    with pytest.raises(ValueError, match="same shape"):
        metric_m(np.ones(2), np.ones(3))


def test_threshold_hand_worked():
    # steps |theta_n - theta_{n-1}| with theta_{-1} = 0: 0, 1, 0.5, 0.1, 0, 0
    theta = np.array([0.0, 1.0, 1.5, 1.6, 1.6, 1.6])
    out = metric_m_at_threshold(theta, 1.6, eps=0.2, sample_rate=1.0, weight1=1, weight2=1)
    assert out == {"convergence_time": 3.0, "convergence_accuracy": 0.0, "M": 3.0}
    # eps = 0.05: the step 0.1 at n = 3 also counts, so convergence at n = 4
    out = metric_m_at_threshold(theta, 1.7, eps=0.05, sample_rate=2.0, weight1=1, weight2=1)
    assert out["convergence_time"] == pytest.approx(2.0)
    assert out["convergence_accuracy"] == pytest.approx(0.1)


def test_stricter_threshold_converges_later():
    # steps 1e-9 * 0.5^n: above 1e-10 up to n = 3, above 5e-11 up to n = 4
    steps = 1e-9 * 0.5 ** np.arange(30)
    theta = 1e-7 + np.cumsum(steps) - steps.sum()
    curves = np.vstack([theta, theta])
    m1 = metric_m_at_threshold(curves, 1e-7, eps=1e-10, theta0=theta[0] - 1e-9 * 2)
    m2 = metric_m_at_threshold(curves, 1e-7, eps=5e-11, theta0=theta[0] - 1e-9 * 2)
    np.testing.assert_allclose(m1["convergence_time"], [0.4, 0.4])
    np.testing.assert_allclose(m2["convergence_time"], [0.5, 0.5])
    # Eq. 19: RMSE over the samples from the convergence index to the end; Eq. 29
    rmse = np.sqrt(np.mean((theta[5:] - 1e-7) ** 2))
    np.testing.assert_allclose(m2["convergence_accuracy"], [rmse, rmse])
    np.testing.assert_allclose(m2["M"], 0.5 / 60 + 1e10 * rmse)


@pytest.mark.parametrize("kwargs, match", [
    ({"eps": 0.0}, "eps"), ({"eps": float("inf")}, "eps"), ({"sample_rate": 0.0}, "sample_rate"),
])
def test_threshold_rejects_bad_parameters(kwargs, match):
    args = {"eps": 1e-10, **kwargs}
    with pytest.raises(ValueError, match=match):
        metric_m_at_threshold(np.ones(5), 1.0, **args)


def test_threshold_rejects_bad_curves():
    with pytest.raises(ValueError, match="shape"):
        metric_m_at_threshold(np.ones((2, 2, 2)), 1.0, eps=1e-10)
    with pytest.raises(ValueError, match="finite"):
        metric_m_at_threshold(np.array([1.0, np.nan]), 1.0, eps=1e-10)
