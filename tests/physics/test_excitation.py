"""Multi-sine reference of Eq. 17."""

import math

import numpy as np
import pytest

from tmopt.physics.excitation import MultiSine, sample_times


def test_starts_at_zero_for_any_phase():
    rng = np.random.default_rng(0)
    ms = MultiSine(rng.uniform(0, 1e-4, (50, 3)), rng.uniform(0, 1, (50, 3)),
                   rng.uniform(-math.pi, math.pi, (50, 3)))  # fmt: skip
    assert np.all(ms.evaluate(np.array([0.0]))[:, 0] == 0.0)


def test_evaluate_matches_eq_17_with_bias():
    a, w, p = np.array([[1e-5, 2e-5]]), np.array([[0.02, 0.05]]), np.array([[0.3, 2.0]])
    t = np.linspace(0, 100, 7)
    expected = sum(a[0, i] * np.sin(w[0, i] * t + p[0, i]) - a[0, i] * np.sin(p[0, i])
                   for i in range(2))  # fmt: skip
    np.testing.assert_allclose(MultiSine(a, w, p).evaluate(t)[0], expected, rtol=1e-14)


def test_shapes_broadcast_and_helpers():
    ms = MultiSine([[1e-4], [2e-5]], 2 * math.pi / 300, 0.0)
    assert (ms.batch_size, ms.n_components) == (2, 1)
    np.testing.assert_allclose(ms.max_accel(), [1e-4, 2e-5] * np.array((2 * math.pi / 300) ** 2))
    # full periods sampled on the paper's grid (1200 s at 10 Hz)
    np.testing.assert_allclose(ms.max_abs(1200.0, 10.0), [1e-4, 2e-5], rtol=1e-6)
    assert ms.take(1).amplitude[0, 0] == 2e-5
    assert sample_times(1.0, 10.0).size == 10


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"amplitude": -1e-5, "omega": 0.1}, "amplitude"),
        ({"amplitude": float("nan"), "omega": 0.1}, "amplitude"),
        ({"amplitude": 1e-5, "omega": float("inf")}, "omega"),
        ({"amplitude": 1e-5, "omega": -0.1}, "omega"),
        ({"amplitude": 1e-5, "omega": 0.1, "phase": float("nan")}, "phase"),
        ({"amplitude": 1e-5, "omega": math.pi * 10, "sample_rate": 10.0}, "Nyquist"),
        ({"amplitude": [1e-5, 1e-5], "omega": [0.1, 0.2, 0.3]}, "broadcast"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(kwargs, match):
    with pytest.raises(ValueError, match=match):
        MultiSine(**kwargs)


def test_ramp_window_starts_smoothly_and_the_simulator_tracks_the_ramped_reference():
    from tmopt.physics.excitation import ramp_window
    from tmopt.physics.simulator import SimulationConfig, simulate

    t = sample_times(200.0, 10.0)
    w = ramp_window(t, 90.0)
    assert w[0] == 0.0 and np.all(w[t >= 90.0] == 1.0) and np.all(np.diff(w) >= 0)
    assert w[1] - w[0] < 1e-5  # zero slope at the start
    assert np.all(ramp_window(t, 0.0) == 1.0)
    ref = MultiSine(5e-5, 2 * math.pi / 300)
    res = simulate(ref, ref, SimulationConfig(duration=200.0, ramp_in=90.0))
    np.testing.assert_array_equal(res.ref_x1[0], ref.evaluate(t)[0] * w)
    with pytest.raises(ValueError, match="ramp_in"):
        SimulationConfig(ramp_in=-1.0)
