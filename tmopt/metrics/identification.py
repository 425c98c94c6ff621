"""The paper's comprehensive metric M (Eq. 29), also at other convergence thresholds.

M combines the two identification objectives, convergence time (Eq. 18) and convergence
accuracy (Eq. 19), as ``M = weight1 * obj1 + weight2 * obj2``. The paper reports M at
the optimisation threshold and at stricter ones (M(7e-11), M(5e-11)): the objectives are
recomputed from the same identification curve with another epsilon. The definitions of
Eqs. 18-19 live in :mod:`tmopt.physics.objectives`; this module reuses them, so there is
one implementation of each equation.
"""

from __future__ import annotations

import numpy as np

from tmopt.physics import objectives as _obj
from tmopt.physics.control import PAPER_RATE


def _check_weight(label: str, value: float) -> float:
    if isinstance(value, bool) or not np.isfinite(value) or value < 0:
        raise ValueError(f"metric M: {label} must be a finite number >= 0, got {value!r}")
    return float(value)


def metric_m(obj1, obj2, weight1: float = _obj.M_WEIGHTS[0],
             weight2: float = _obj.M_WEIGHTS[1]) -> np.ndarray | float:
    """Paper Eq. 29: ``M = weight1 * obj1 + weight2 * obj2``.

    Args:
        obj1: Convergence time(s) in s (Eq. 18), scalar or array.
        obj2: Convergence accuracy (RMSE, Eq. 19) in s^-2, same shape as ``obj1``.
        weight1: Weight of the time [s^-1] (default: Eq. 29's, 1/60).
        weight2: Weight of the accuracy [s^2] (default: Eq. 29's, 1e10).

    Returns:
        M with the shape of the inputs (a float for scalars).
    """
    w1, w2 = _check_weight("weight1", weight1), _check_weight("weight2", weight2)
    a, b = np.asarray(obj1, dtype=float), np.asarray(obj2, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"metric M: obj1 and obj2 must have the same shape, got {a.shape} "
                         f"and {b.shape}")
    m = _obj.metric_m(a, b, (w1, w2))
    return float(m) if np.ndim(m) == 0 else m


def metric_m_at_threshold(theta_hat, theta_true: float, eps: float,
                          sample_rate: float = PAPER_RATE, weight1: float = _obj.M_WEIGHTS[0],
                          weight2: float = _obj.M_WEIGHTS[1], theta0: float = 0.0) -> dict:
    """M of an identification curve for convergence threshold ``eps`` (e.g. M(7e-11)).

    Convergence time (Eq. 18): the first sample time t such that
    ``|theta_n - theta_{n-1}| <= eps`` for every n >= t (``theta_{-1} = theta0``, the
    estimator's initial value); a curve that never settles gets the run duration.
    Accuracy (Eq. 19): RMSE of ``theta_n - theta_true`` from that sample to the end.

    Args:
        theta_hat: Estimates per sample, shape (N,) or (B, N) for B curves.
        theta_true: True parameter value.
        eps: Convergence threshold (> 0), e.g. 1e-10, 7e-11, 5e-11.
        sample_rate: Samples per second (> 0).
        weight1, weight2: Weights of Eq. 29.
        theta0: Estimate before the first sample.

    Returns:
        ``{"convergence_time", "convergence_accuracy", "M"}``: floats for one curve,
        arrays (B,) for several.
    """
    th = np.asarray(theta_hat, dtype=float)
    if th.ndim not in (1, 2) or th.shape[-1] < 1:
        raise ValueError(f"metric M: theta_hat must have shape (N,) or (B, N), got {th.shape}")
    if not np.all(np.isfinite(th)) or not np.isfinite(theta_true):
        raise ValueError("metric M: theta_hat and theta_true must be finite")
    if not (np.isfinite(eps) and eps > 0):
        raise ValueError(f"metric M: eps must be a finite number > 0, got {eps!r}")
    if not (np.isfinite(sample_rate) and sample_rate > 0):
        raise ValueError(f"metric M: sample_rate must be > 0, got {sample_rate!r}")
    curves = th[None] if th.ndim == 1 else th
    t = _obj.convergence_time(curves, eps=eps, sample_rate=sample_rate, theta0=theta0)
    acc = _obj.convergence_accuracy(curves, theta_true, eps=eps, theta0=theta0)
    m = metric_m(t, acc, weight1, weight2)
    out = {"convergence_time": t, "convergence_accuracy": acc, "M": m}
    return {k: float(v[0]) for k, v in out.items()} if th.ndim == 1 else out
