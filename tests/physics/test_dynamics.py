"""Exact ZOH discretisation vs closed forms (Eqs. 1-2 along one axis)."""

import numpy as np
import pytest
from scipy.linalg import expm

from tmopt.physics.control import ControllerSettings
from tmopt.physics.dynamics import free_motion, zoh_coefficients, zoh_step
from tmopt.physics.simulator import SimulationConfig, simulate


@pytest.mark.parametrize("k", [1e-7, -1e-7, 0.0, 2e-7, 1e-2, -1e-2, 50.0, -50.0])
def test_zoh_coefficients_match_matrix_exponential(k):
    h = 0.1
    # augmented system [r, v, a]' = [[0,1,0],[k,0,1],[0,0,0]] [r, v, a]
    m = expm(np.array([[0, 1, 0], [k, 0, 1], [0, 0, 0]], dtype=float) * h)
    c, s, g = zoh_coefficients(k, h)
    np.testing.assert_allclose([c, s, k * s, g, s], [m[0, 0], m[0, 1], m[1, 0], m[0, 2], m[1, 2]],
                               rtol=1e-13, atol=1e-300)  # fmt: skip


@pytest.mark.parametrize("k", [1e-7, -1e-7, 1e-3, -1e-3, 0.0])
def test_repeated_zoh_steps_follow_free_motion(k):
    h, n = 0.1, 12000
    r0, v0, a = 2e-6, -3e-8, 1e-10
    c, s, g = zoh_coefficients(k, h)
    r, v = r0, v0
    rs = np.empty(n + 1)
    rs[0] = r
    for i in range(n):
        r, v = zoh_step(r, v, a, k, c, s, g)
        rs[i + 1] = r
    exact, _ = free_motion(k, r0, v0, a, np.arange(n + 1) * h)
    # closed form itself loses digits in (r0 + a/k) cos - a/k: absolute tolerance too
    np.testing.assert_allclose(rs, exact, rtol=1e-9, atol=1e-9 * np.abs(exact).max())


def test_open_loop_simulation_is_free_motion_with_stiffness():
    """Gains 0, no noise, no f_B: each axis is r'' = k r + f_D from rest (cosh form)."""
    zero = ControllerSettings(base_gains=(0, 0, 0), y_gains=(0, 0, 0))
    cfg = SimulationConfig(
        controller="pid", control=zero, sigma_m1=0, sigma_m2=0, sigma_acc=0, sigma_ele=0,
        fb_bias=(0, 0), fb_sigma=0, stiffness_1=(1e-4, -2e-4), stiffness_2=(2e-7, 0.0),
        bias_1=(1e-10, -2e-10), bias_2=(3e-10, 1e-10), divergence_bound=10.0,
    )  # fmt: skip
    res = simulate(np.zeros(cfg.n_steps), np.zeros(cfg.n_steps), cfg)
    t = res.time
    for name, k, fd in [("x1_true", 1e-4, 1e-10), ("y1_true", -2e-4, -2e-10),
                        ("x2_true", 2e-7, 3e-10), ("y2_true", 0.0, 1e-10)]:  # fmt: skip
        exact, _ = free_motion(k, 0.0, 0.0, fd, t)
        tol = 1e-9 * np.abs(exact).max()  # absolute near the zero crossings of the cos form
        np.testing.assert_allclose(getattr(res, name)[0], exact, rtol=1e-9, atol=tol)
        # measured acceleration = k r + f_D exactly when noise-free
        acc = getattr(res, "acc_" + name[:2])[0]
        np.testing.assert_allclose(acc, k * exact + fd, rtol=1e-9, atol=abs(k) * tol)
    assert np.all(res.force_x1 == 0)
