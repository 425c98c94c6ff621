"""Regression of Eqs. 10-15, f_B cancellation, and RLS (Eq. 16) vs batch least squares."""

import math
from dataclasses import replace

import numpy as np
import pytest

from tmopt.physics.excitation import MultiSine
from tmopt.physics.identification import (
    batch_least_squares,
    regressors,
    regressors_from_result,
    rls,
)
from tmopt.physics.simulator import SimulationConfig, simulate

REF1 = MultiSine(5e-5, 2 * math.pi / 300)
REF2 = MultiSine(3e-5, 2 * math.pi / 500)
SCALES = np.array([1e-5, 1e-5, 1e-8, 1e-8, 1.0])


def _residual(res):
    y, psi = regressors_from_result(res)
    return y - psi @ res.config.theta_true


def test_rls_equals_batch_least_squares_with_the_same_prior():
    rng = np.random.default_rng(1)
    b, n, p = 3, 2000, 5
    psi = rng.normal(size=(b, n, p)) * [1.0, 2.0, 0.5, 3.0, 1.0]
    y = psi @ [1.0, -2.0, 0.5, 3.0, 0.1] + 0.1 * rng.normal(size=(b, n))
    th = rls(y, psi, lam=1.0, P0=1e6)
    exact = batch_least_squares(y, psi, P0=1e6)
    np.testing.assert_allclose(th[:, -1], exact, rtol=1e-10, atol=1e-12)
    # and the prior is negligible: plain least squares agrees to ~1/(P0 * sum psi^2)
    np.testing.assert_allclose(th[:, -1], batch_least_squares(y, psi), rtol=1e-7, atol=1e-9)
    # every intermediate estimate is the batch solution on the data so far
    np.testing.assert_allclose(th[:, 99], batch_least_squares(y[:, :100], psi[:, :100], 1e6),
                               rtol=1e-9, atol=1e-11)  # fmt: skip


def test_rls_with_forgetting_is_exponentially_weighted_least_squares():
    rng = np.random.default_rng(2)
    n, lam = 500, 0.98
    psi = rng.normal(size=(1, n, 2))
    y = psi @ [0.3, -1.0] + 0.05 * rng.normal(size=(1, n))
    th = rls(y, psi, lam=lam, P0=1e3)[0, -1]
    w = np.sqrt(lam ** np.arange(n - 1, -1, -1))
    # prior weight decays like the data: lam^N P0^-1
    exact = batch_least_squares((y[0] * w)[None], (psi[0] * w[:, None])[None],
                                P0=1e3 / lam**n)[0]  # fmt: skip
    np.testing.assert_allclose(th, exact, rtol=1e-9)


def test_closed_loop_estimates_are_rls_on_the_recorded_regression():
    res = simulate(REF1, REF2, SimulationConfig(duration=300.0, rls_columns="all"))
    y, psi = regressors_from_result(res)
    cfg = res.config
    th = rls(y, psi, cfg.rls_lambda, cfg.rls_p0, scales=SCALES, y_scale=cfg.rls_scales[2])
    np.testing.assert_allclose(th, res.theta_hat, rtol=1e-12, atol=1e-25)
    scaled_y = y / 1e-12
    np.testing.assert_allclose(
        rls(scaled_y, psi / SCALES, 1.0, cfg.rls_p0)[:, -1],
        batch_least_squares(scaled_y, psi / SCALES, P0=cfg.rls_p0), rtol=1e-8,
    )  # fmt: skip


def test_leaving_columns_out_is_rls_on_the_reduced_regression():
    """The kernel's column mask (zero prior covariance) equals an RLS without the columns."""
    cfg = SimulationConfig(duration=300.0)
    assert cfg.rls_columns == ("k1xx", "k2xx", "R")
    res = simulate(REF1, REF2, cfg)
    y, psi = regressors_from_result(res)
    keep = [0, 1, 4]
    th = rls(y, psi[..., keep], cfg.rls_lambda, cfg.rls_p0, scales=SCALES[keep],
             y_scale=cfg.rls_scales[2])  # fmt: skip
    np.testing.assert_allclose(th, res.theta_hat[..., keep], rtol=1e-12, atol=1e-25)
    assert np.all(np.isnan(res.theta_hat[..., [2, 3]]))


def test_regression_is_exact_without_noise():
    cfg = SimulationConfig(duration=200.0, sigma_m1=0, sigma_m2=0, sigma_acc=0, sigma_ele=0,
                           fb_sigma=0)  # fmt: skip
    res = simulate(REF1, REF2, cfg)
    y, _ = regressors_from_result(res)
    assert np.max(np.abs(_residual(res))) < 1e-9 * np.max(np.abs(y)) + 1e-24


def test_spacecraft_acceleration_cancels_in_the_regression():
    """Runs differing only in f_B move differently, but their equation errors coincide."""
    base = SimulationConfig(duration=300.0)
    quiet = replace(base, fb_bias=(0.0, 0.0), fb_sigma=0.0)
    loud = replace(base, fb_bias=(3e-9, -2e-9), fb_sigma=1e-9)
    r_quiet, r_loud = simulate(REF1, REF2, quiet), simulate(REF1, REF2, loud)
    assert np.max(np.abs(r_quiet.x1_true - r_loud.x1_true)) > 1e-10  # f_B did act
    diff = _residual(r_quiet) - _residual(r_loud)
    assert np.max(np.abs(diff)) < 1e-20  # rounding only; the equation noise is ~1.7e-12
    # a combination that is not the null vector sees f_B at full strength
    wrong = np.array([1.0, -1.0, 0.0, 0.0])
    ax = ("x1", "x2", "y1", "y2")
    leak = []
    for r in (r_quiet, r_loud):
        acc = np.stack([getattr(r, f"acc_{a}") for a in ax], 1)
        force = np.stack([getattr(r, f"force_{a}") for a in ax], 1)
        leak.append(regressors(acc, force, acc, wrong)[0])
    assert np.max(np.abs(leak[0] - leak[1])) > 1e-9


def test_equation_noise_level():
    res = simulate(REF1, REF2, SimulationConfig(duration=600.0))
    k = res.config.coefficients
    expected = np.linalg.norm(k) * math.hypot(1e-12, 1e-12)  # K.(N_ele + N_acc)
    assert np.std(_residual(res)) == pytest.approx(expected, rel=0.05)


def test_identified_stiffness_is_within_its_standard_error():
    res = simulate(REF1, REF2, SimulationConfig())
    k = res.config.coefficients
    sigma_eq = np.linalg.norm(k) * math.sqrt(2) * 1e-12
    se = sigma_eq / math.sqrt(k[0] ** 2 * np.sum(res.x1[0] ** 2))  # ~1e-9 s^-2
    assert abs(res.theta_hat[0, -1, 0] - 1e-7) < 5 * se
