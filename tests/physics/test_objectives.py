"""Objectives (Eqs. 18-19, 29), final accuracy and Eq. 20 constraints on hand-worked cases."""

import math

import numpy as np
import pytest

from tmopt.physics.excitation import MultiSine
from tmopt.physics.objectives import (
    convergence_accuracy,
    convergence_index,
    convergence_time,
    eq20_constraints,
    evaluate,
    final_accuracy,
    metric_m,
)
from tmopt.physics.simulator import SimulationConfig, simulate

SEQ = np.array([[1.0, 2.0, 2.2, 2.3, 2.3], [0.0, 1.0, 0.0, 1.0, 0.0], [0.0] * 5])


def test_convergence_time_eq_18():
    # diffs from theta_{-1} = 0: [1, 1, .2, .1, 0] -> last move > 0.5 at n = 1 -> n* = 2
    np.testing.assert_array_equal(convergence_index(SEQ, eps=0.5), [2, 5, 0])
    np.testing.assert_allclose(convergence_time(SEQ, eps=0.5, sample_rate=10.0), [0.2, 0.5, 0.0])


def test_convergence_accuracy_eq_19_is_rmse_after_convergence():
    got = convergence_accuracy(SEQ, theta_true=2.3, eps=0.5)
    assert got[0] == pytest.approx(math.sqrt(0.1**2 / 3))  # samples 2..4
    assert got[1] == pytest.approx(2.3)  # never converged: error of the last sample
    assert got[2] == pytest.approx(2.3)  # converged from n = 0: RMSE of all samples


def test_final_accuracy_and_metric_m():
    np.testing.assert_allclose(final_accuracy(SEQ, 2.0), [0.3, 2.0, 2.0])
    assert metric_m(120.0, 1e-10) == pytest.approx(2.0 + 1.0)
    assert metric_m(60.0, 0.0, weights=(1.0, 1.0)) == 60.0


def test_3d_estimates_pick_the_parameter_index():
    th = np.stack([SEQ, 2 * SEQ], axis=2)
    np.testing.assert_array_equal(convergence_index(th, idx=0, eps=0.3), [2, 5, 0])
    np.testing.assert_array_equal(convergence_index(th, idx=1, eps=0.3), [3, 5, 0])


def test_eq20_constraints():
    cfg = SimulationConfig()
    ref1 = MultiSine([[1e-4], [3e-4]], 0.02, 0.0)  # feasible / violates the 0.4 mm bound
    ref2 = MultiSine([[1e-5], [1e-5]], [[0.02], [0.1]], 0.0)  # 1e-7 > 0.5 F_max: violates
    g = eq20_constraints(ref1, ref2, cfg)
    np.testing.assert_allclose(g[:, 0], [1e-4 * 4e-4 - 5e-8, 3e-4 * 4e-4 - 5e-8])
    np.testing.assert_allclose(g[:, 1], [1e-4 - 4e-4, 3e-4 - 4e-4], rtol=1e-5)
    assert g[0, 1] < 0 and g[1, 1] < 0
    np.testing.assert_allclose(g[:, 2], [1e-5 * 4e-4 - 5e-8, 1e-5 * 1e-2 - 5e-8])
    assert g[1, 2] > 0


def test_evaluate_on_a_simulation():
    res = simulate(MultiSine(5e-5, 2 * math.pi / 300), MultiSine(3e-5, 2 * math.pi / 500))
    ev = evaluate(res, idx=0)
    assert 0 < ev["convergence_time"][0] < 1200
    assert 1e-11 < ev["convergence_accuracy"][0] < 1e-8
    assert ev["feasible"][0] and ev["reason"] == [""]
    assert ev["M"][0] == pytest.approx(ev["convergence_time"][0] / 60
                                       + 1e10 * ev["convergence_accuracy"][0])  # fmt: skip


def test_eq20_realised_is_on_the_simulated_motion_and_command():
    from tmopt.physics.objectives import eq20_realised

    cfg = SimulationConfig(duration=300.0, ramp_in=0.0)
    res = simulate(MultiSine(5e-5, 2 * math.pi / 300), MultiSine(3e-5, 2 * math.pi / 500), cfg)
    g = eq20_realised(res)[0]
    x1, u1 = np.abs(res.x1_true[0]).max(), np.abs(res.force_x1[0]).max()
    assert g[0] == pytest.approx(u1 - 0.5 * 1e-7) and g[1] == pytest.approx(x1 - 0.1 * 4e-3)
    assert g[3] == pytest.approx(np.abs(res.x2_true[0]).max() - 4e-4)
    # the abrupt start of Eq. 17 saturates the actuator: the command reaches F_max
    assert u1 == pytest.approx(1e-7) and res.max_abs_command[0, 0] == u1
