"""What a design's regressors say about the identified stiffness, without a noise draw.

The RLS of Eq. 16 with ``lambda = 1`` is least squares with a prior: its estimate's
covariance is ``sigma_e^2 P_n`` and ``P_n`` depends on the regressors ``psi_n`` only, not
on the measured outputs (Ljung, *System Identification*, 2nd ed., 1999, Sec. 11.2).  So
one *noise-free* closed-loop run of a design -- its realised motion and the deterministic
estimate trajectory -- and the known equation-noise level ``sigma_e`` (Eq. 10 with Table
1's N_acc and N_ele through K, Eq. 11) give the distribution of every quantity of Eqs.
18-19 (classic optimal experiment design: Fedorov, *Theory of Optimal Experiments*, 1972;
Goodwin & Payne, *Dynamic System Identification*, 1977):

* the estimation error ``err_n = b_n + delta_n``: ``b_n`` the noise-free run's error,
  ``delta_n`` Gaussian with ``Cov(delta_n, delta_m) = v_max(n, m)``, ``v_n = sigma_e^2
  P_n[jj]`` (least squares is a martingale: the error at the later time is uncorrelated
  with everything before);
* the RLS steps ``theta_n - theta_{n-1}``: independent Gaussians with mean ``d_n`` (the
  noise-free steps) and variance ``v_{n-1} - v_n``;
* Eq. 18's convergence index ``n*`` (one past the last step larger than epsilon):
  ``P(n* <= n) = prod_{m >= n} P(|step_m| <= eps)``, hence its expectation;
* Eq. 19's RMSE after ``n*``: for each ``n*`` the mean square ``Q`` is a Gaussian
  quadratic form whose mean and variance are exact sums over the covariance above;
  ``E sqrt(Q)`` uses the moment-matched gamma law of ``Q`` (Satterthwaite, *Biometrics
  Bulletin* 2, 1946), averaged over the law of ``n*`` (treated as independent of the
  errors after it);
* the final error ``|err_N|``: a folded normal.

:func:`predict` returns these expectations for a batch of noise-free runs; the stiffness
problem's ``noise="information"`` uses them as objectives, and
``tests/physics/test_information.py`` and docs/noise.md check them against many noise
seeds of the simulator.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import gammaln, ndtr

from tmopt.physics import _closed_loop as cl
from tmopt.physics.identification import regressors_from_result
from tmopt.physics.objectives import EPSILON, M_WEIGHTS, PARAMETERS

__all__ = ["equation_noise_sigma", "noise_free", "covariance_trajectory", "predict",
           "convergence_law", "expected_rms_after"]  # fmt: skip


def equation_noise_sigma(config) -> float:
    """Per-sample standard deviation of the regression's equation error (Eq. 10) [m s^-2].

    ``y_n - psi_n' theta = K . (N_ele + N_acc) - sum_a K_a k_a N_m,a``: the applied force's
    and the accelerometer's noise through K (Eq. 11) and the displacement readout noise
    of every identified stiffness column (errors in variables; ~1e-18 here).  The
    spacecraft acceleration cancels (docs/decisions.md).  Table 1 at 10 Hz:
    ``|K| sqrt(2) 1e-12 = 1.73e-12``.
    """
    k = np.asarray(config.coefficients, dtype=float)
    var = float(np.sum(k**2)) * (config.sigma_ele**2 + config.sigma_acc**2)
    truth = config.theta_true
    sig_m = (config.sigma_m1, config.sigma_m1, config.sigma_m2, config.sigma_m2)
    for a in range(4):
        if config.identified[a]:
            var += (k[a] * truth[a] * sig_m[a]) ** 2
    return math.sqrt(var)


def noise_free(config):
    """``config`` with every noise source off (Table 1's sigmas and f_B's): the run whose
    regressors and estimate trajectory :func:`predict` needs."""
    from dataclasses import replace

    return replace(config, sigma_m1=0.0, sigma_m2=0.0, sigma_acc=0.0, sigma_ele=0.0,
                   fb_sigma=0.0)  # fmt: skip


def _psi_scales(config) -> np.ndarray:
    sx, sy, _ = config.rls_scales
    return np.array([sx, sx, sy, sy, 1.0])


def covariance_trajectory(result, idx: tuple[int, ...] = (0,)) -> np.ndarray:
    """``P_n[j, j] / s_j^2`` for each j of ``idx``, shape (B, N, len(idx)) [s^-4 / (m s^-2)^2].

    Times ``sigma_e^2`` this is the variance of the estimate of theta_j after sample n on
    the run's measured regressors (``result`` recorded with ``record="full"``): the very
    recursion of the closed loop (``_closed_loop.rls_covariance_kernel``) on the scaled
    regressors, with the columns the RLS leaves out at zero prior covariance.
    """
    cfg = result.config
    if result.channels is None:
        raise ValueError("covariance_trajectory needs a run recorded with record='full'")
    _, psi = regressors_from_result(result)
    scales = _psi_scales(cfg)
    psi = np.ascontiguousarray(psi / scales)
    p0 = np.diag(cfg.rls_p0 * cfg.identified.astype(float))
    out = np.empty((psi.shape[0], psi.shape[1], len(idx)))
    cl.rls_covariance_kernel(psi, float(cfg.rls_lambda), p0, np.asarray(idx, np.int64), out)
    return out / (scales[list(idx)] ** 2)[None, None, :]


def convergence_law(step_mean: np.ndarray, step_sd: np.ndarray, eps: float) -> np.ndarray:
    """``P(n* = n)`` for n = 0..N, shape (B, N + 1), from independent Gaussian steps.

    Step m (``theta_m - theta_{m-1}``) has mean ``step_mean[:, m]`` and standard deviation
    ``step_sd[:, m]``; Eq. 18's ``n*`` is one past the last step with ``|step| > eps``, so
    ``P(n* <= n) = prod_{m >= n} P(|step_m| <= eps)``.
    """
    sd = np.maximum(step_sd, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        inside = ndtr((eps - step_mean) / sd) - ndtr((-eps - step_mean) / sd)
    inside = np.where(sd > 0, inside, (np.abs(step_mean) <= eps).astype(float))
    with np.errstate(divide="ignore"):
        logp = np.log(np.clip(inside, 0.0, 1.0))
    # suffix sums: log P(n* <= n) for n = 0..N-1, then P(n* <= N) = 1
    tail = np.flip(np.cumsum(np.flip(logp, axis=1), axis=1), axis=1)
    cdf = np.concatenate([np.exp(tail), np.ones((tail.shape[0], 1))], axis=1)
    return np.diff(cdf, axis=1, prepend=0.0)


def expected_rms_after(bias: np.ndarray, var: np.ndarray) -> np.ndarray:
    """``E sqrt(mean_{n >= s} err_n^2)`` for every start s = 0..N-1, shape (B, N).

    ``err_n = bias_n + delta_n`` with ``Cov(delta_n, delta_m) = var_max(n, m)``.  The mean
    square Q has exact mean and variance (suffix sums, O(N)); ``E sqrt(Q)`` is that of the
    gamma law with the same two moments: ``sqrt(scale) Gamma(k + 1/2) / Gamma(k)``.
    """
    b, v = np.asarray(bias, float), np.asarray(var, float)
    n = b.shape[1]
    count = n - np.arange(n)[None, :]

    def suffix(x):
        return np.flip(np.cumsum(np.flip(x, axis=1), axis=1), axis=1)

    mean = suffix(b**2 + v) / count
    v2 = suffix(v**2)  # sum_{m >= s} v_m^2
    # sum_{n, m >= s} v_max^2 = V2(s) + 2 sum_{m > s} V2(m)
    pairs_v = v2 + 2 * np.concatenate([suffix(v2)[:, 1:], np.zeros((b.shape[0], 1))], axis=1)
    u_next = np.concatenate([suffix(v * b)[:, 1:], np.zeros((b.shape[0], 1))], axis=1)
    # sum_{n, m >= s} b_n b_m v_max: add row/column s to the block after it
    pairs_b = suffix(b * (v * b + 2 * u_next))
    var_q = np.maximum(2 * pairs_v + 4 * pairs_b, 0.0) / count**2
    return _gamma_sqrt_mean(mean, var_q)


def _gamma_sqrt_mean(mean: np.ndarray, var: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        shape = np.where(var > 0, mean**2 / var, np.inf)
        scale = np.where(var > 0, var / mean, 0.0)
        big = shape > 1e6
        small = np.where(big, 1.0, shape)
        ratio = np.exp(gammaln(small + 0.5) - gammaln(small)) * np.sqrt(scale)
        # Gamma(k + 1/2) / Gamma(k) ~ sqrt(k) (1 - 1/(8 k)) for large k
        asym = np.sqrt(np.maximum(mean, 0.0)) * (1 - 1 / (8 * np.where(big, shape, 1.0)))
    return np.where(big, asym, ratio)


def predict(
    result,
    sigma_e: float,
    idx: int = 0,
    eps: float = EPSILON,
    weights: tuple[float, float] = M_WEIGHTS,
) -> dict[str, np.ndarray]:
    """Expected Eqs. 18, 19, 29 and final accuracy of the batch's designs, no noise drawn.

    Args:
        result: A noise-free run (:func:`noise_free` configuration, ``record="full"``).
        sigma_e: Equation-noise level of the noisy problem (:func:`equation_noise_sigma`).
        idx: theta column (0: k1xx, 1: k2xx).
        eps: Eq. 18's threshold [s^-2].
        weights: Eq. 29's weights.

    Returns:
        Arrays (B,): ``convergence_time`` (E n* / fs) [s], ``convergence_accuracy``
        (E obj2) [s^-2], ``final_accuracy`` (E |err_N|) [s^-2], ``M`` (Eq. 29 of the two
        expectations), ``final_sd`` (the estimate's standard deviation at the end, i.e.
        its Cramer-Rao bound on these regressors) and ``convergence_sd`` (of n* / fs).
        Diverged designs get the duration and the noise-free run's numbers.
    """
    cfg = result.config
    if not cfg.identified[idx]:
        raise ValueError(f"theta column {PARAMETERS[idx]} is not identified by this run")
    truth = float(cfg.theta_true[idx])
    theta = result.theta_hat[:, :, idx]
    b, n = theta.shape
    var = sigma_e**2 * covariance_trajectory(result, (idx,))[:, :, 0]
    prior = sigma_e**2 * cfg.rls_p0 / _psi_scales(cfg)[idx] ** 2
    var_prev = np.concatenate([np.full((b, 1), prior), var[:, :-1]], axis=1)
    step_mean = np.diff(theta, axis=1, prepend=0.0)  # theta_{-1} = 0, the RLS start
    step_sd = np.sqrt(np.maximum(var_prev - var, 0.0))
    law = convergence_law(step_mean, step_sd, eps)  # (B, N + 1)
    index = np.arange(n + 1)
    t_mean = law @ index / cfg.sample_rate
    t_sd = np.sqrt(np.maximum(law @ index**2 / cfg.sample_rate**2 - t_mean**2, 0.0))
    rms = expected_rms_after(theta - truth, var)  # start s = 0..N-1
    rms = np.concatenate([rms, rms[:, -1:]], axis=1)  # n* = N: the last sample's error
    obj2 = np.sum(law * rms, axis=1)
    final = _folded_normal_mean(theta[:, -1] - truth, np.sqrt(var[:, -1]))
    t_mean = np.where(result.diverged, n / cfg.sample_rate, t_mean)
    return {
        "convergence_time": t_mean,
        "convergence_accuracy": obj2,
        "final_accuracy": final,
        "M": weights[0] * t_mean + weights[1] * obj2,
        "final_sd": np.sqrt(var[:, -1]),
        "convergence_sd": t_sd,
    }


def _folded_normal_mean(mu: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """``E |mu + sd Z|``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(sd > 0, mu / sd, 0.0)
        folded = sd * np.sqrt(2 / np.pi) * np.exp(-0.5 * z**2) + mu * (1 - 2 * ndtr(-z))
    return np.where(sd > 0, folded, np.abs(mu))
