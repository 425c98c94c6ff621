"""Controllers (Sec. 3.3): the FRBF-PID adapts its gains by the gradient of Eqs. 26-27, the
non-sensitive axes' filtered PID is Eq. 28 at a = 0 and holds y without saturating."""

import math
from dataclasses import replace

import numpy as np
import pytest

from tmopt.physics._closed_loop import N_MF, N_RULE
from tmopt.physics.control import (
    ControllerSettings,
    closed_loop_poles,
    filtered_pid_increment,
    frbf_forward,
    frbf_learn,
    pid_increment,
)
from tmopt.physics.excitation import MultiSine
from tmopt.physics.scenario import config_at_rate
from tmopt.physics.simulator import SimulationConfig, simulate

REF1 = MultiSine(5e-5, 2 * math.pi / 300)
REF2 = MultiSine(3e-5, 2 * math.pi / 500)


def _network(seed):
    rng = np.random.default_rng(seed)
    c = np.tile(np.array(ControllerSettings().centres), (2, 1)) + rng.normal(0, 0.05, (2, N_MF))
    b = rng.uniform(0.15, 0.4, (2, N_MF))
    w = rng.normal(0, 0.3, (3, N_RULE))
    return c, b, w


def _f4(x1, x2, c, b, w):
    f2, f3, f4 = np.empty((2, N_MF)), np.empty(N_RULE), np.empty(3)
    frbf_forward(x1, x2, c, b, w, f2, f3, f4)
    return f4, f3


def test_frbf_learning_steps_are_minus_eta_times_the_finite_difference_gradient():
    """Eq. 27 without momentum: every parameter moves by -eta dL/dp, L = g . f4(p)."""
    x1, x2, eta = 0.31, -0.17, 0.1
    g = np.array([0.7, -1.3, 0.4])  # dE/df4
    c, b, w = _network(3)
    _, f3 = _f4(x1, x2, c, b, w)
    c1, b1, w1 = c.copy(), b.copy(), w.copy()
    dc, db, dw, q = np.zeros_like(c), np.zeros_like(b), np.zeros_like(w), np.empty(N_RULE)
    frbf_learn(x1, x2, g, c1, b1, w1, dc, db, dw, f3, q, eta, 0.0, 1e-6,
               np.empty((2, 7)))

    def loss(cc, bb, ww):
        return float(g @ _f4(x1, x2, cc, bb, ww)[0])

    h = 1e-6  # central differences: truncation ~h^2 / b^3, rounding ~1e-16 / h
    for arr, new, name in ((c, c1, "c"), (b, b1, "b"), (w, w1, "w")):
        for idx in [(0, 2), (1, 4), (0, 6)] if arr.ndim == 2 and arr.shape[0] == 2 else \
                [(0, 3), (2, 24), (1, 48)]:
            plus, minus = [a.copy() for a in (c, b, w)], [a.copy() for a in (c, b, w)]
            k = "cbw".index(name)
            plus[k][idx] += h
            minus[k][idx] -= h
            grad = (loss(*plus) - loss(*minus)) / (2 * h)
            assert new[idx] - arr[idx] == pytest.approx(-eta * grad, rel=1e-4, abs=1e-10)


def _pulse_runs():
    cfg = SimulationConfig(duration=400.0, ramp_in=0.0)
    t = np.arange(cfg.n_steps) / cfg.sample_rate
    pulse = 1e-5 * ((t % 600.0) < 300.0)
    runs = {c: simulate(pulse, np.zeros_like(pulse), replace(cfg, controller=c))
            for c in ("pid", "frbf_pid")}  # fmt: skip
    return pulse, runs


def test_frbf_pid_adapts_its_gains_and_differs_from_the_pid_on_the_fig5_pulse():
    pulse, runs = _pulse_runs()
    base = np.array(ControllerSettings().base_gains)[:, None]
    pid_gains = runs["pid"].gains[:3, 0]
    np.testing.assert_array_equal(pid_gains, np.broadcast_to(base, pid_gains.shape))
    ratio = runs["frbf_pid"].gains[:3, 0] / base
    assert ratio[:, 0] == pytest.approx(1.0)  # starts as the PID (weights 0)
    assert np.ptp(ratio, axis=1).max() > 0.5  # ... and the gains really move
    gap = np.abs(runs["frbf_pid"].x1_true[0] - runs["pid"].x1_true[0]).max()
    assert gap > 1e-6  # a tenth of the pulse: not the same controller


def test_online_jacobian_option_changes_the_learning():
    cfg = SimulationConfig(duration=100.0, ramp_in=0.0)
    online = replace(cfg, control=replace(cfg.control, jacobian="online"))
    a, b = simulate(REF1, REF2, cfg), simulate(REF1, REF2, online)
    assert not np.array_equal(a.gains, b.gains)
    with pytest.raises(ValueError, match="jacobian"):
        ControllerSettings(jacobian="minus")


def test_filtered_pid_without_filter_is_eq28():
    rng = np.random.default_rng(0)
    for _ in range(50):
        e, e1, e2, u = rng.normal(size=4) * 1e-6
        d_prev = 10.0 * (e1 - e2)  # the unfiltered derivative term of the last step
        u_f, d = filtered_pid_increment(e, e1, u, d_prev, 0.5, 0.01, 10.0, 0.0, 1.0)
        assert u_f == pytest.approx(pid_increment(e, e1, e2, u, 0.5, 0.01, 10.0, 1.0),
                                    rel=1e-12, abs=1e-20)  # fmt: skip
        assert d == pytest.approx(10.0 * (e - e1))


def test_default_y_loop_is_stable_damped_and_quiet():
    ctl = ControllerSettings()
    poles = closed_loop_poles(ctl.y_gains, 0.1, ctl.y_derivative_filter)
    assert np.all(np.abs(poles) < 1)
    s = np.log(poles.astype(complex)) / 0.1
    slow = s[s.real > -5]  # the loop's poles (the filter's own pole is fast)
    assert np.min(-slow.real / np.abs(slow)) >= 0.4  # damping ratio
    res = simulate(REF1, REF2, SimulationConfig(duration=300.0))
    force = res.force_y1[0, 200:]
    assert np.std(force) < res.config.f_max / 6  # readout noise does not saturate y
    assert np.max(np.abs(res.y1_true[0, 200:])) < 2e-8  # held at the readout-noise level


def test_round1_y_axes_are_the_slow_loop_with_spacecraft_bias():
    cfg = config_at_rate(y_axes="round1")
    assert cfg.control.y_gains == (0.005, 1e-5, 1.0) and cfg.control.y_derivative_filter == 0
    assert cfg.fb_bias == (1e-10, 1e-10) and cfg.fb_sigma == 1e-10
    assert SimulationConfig().fb_bias == (0.0, 0.0) and SimulationConfig().fb_sigma == 0.0
    with pytest.raises(ValueError, match="y_axes"):
        config_at_rate(y_axes="lisa")
