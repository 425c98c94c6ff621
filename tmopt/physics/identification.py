"""Stiffness identification: regression of Eqs. 10-15 and recursive least squares (Eq. 16)."""

from __future__ import annotations

import numpy as np

from tmopt.physics._closed_loop import rls_batch_kernel, rls_update

__all__ = ["regressors", "regressors_from_result", "rls", "batch_least_squares", "rls_update"]


def regressors(
    acc: np.ndarray, force: np.ndarray, disp: np.ndarray, coefficients: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 10-15: ``y_n = K . (r''_n - f_e,n)`` and ``psi_n = [K1 x1, K2 x2, K3 y1, K4 y2, 1]``.

    ``acc`` (measured accelerations), ``force`` (commanded electrostatic forces) and
    ``disp`` (measured displacements) have shape (B, 4, N), axes ordered
    ``[x1, x2, y1, y2]``; ``coefficients`` is K of Eq. 11.  Returns ``y`` (B, N) and
    ``psi`` (B, N, 5) so that ``y = psi . theta`` with
    ``theta = [k1xx, k2xx, k1yy, k2yy, R]``, ``R = K . f_D``.
    """
    k = np.asarray(coefficients, dtype=np.float64).reshape(1, 4, 1)
    acc, force, disp = (np.asarray(v, dtype=np.float64) for v in (acc, force, disp))
    y = np.sum(k * (acc - force), axis=1)
    psi = np.concatenate([k * disp, np.ones_like(disp[:, :1])], axis=1)
    return y, np.ascontiguousarray(np.moveaxis(psi, 1, 2))


def regressors_from_result(result) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 10-15 from a recorded :class:`~tmopt.physics.simulator.SimulationResult`."""
    ax = ("x1", "x2", "y1", "y2")
    acc = np.stack([getattr(result, f"acc_{a}") for a in ax], axis=1)
    force = np.stack([getattr(result, f"force_{a}") for a in ax], axis=1)
    disp = np.stack([getattr(result, a) for a in ax], axis=1)
    return regressors(acc, force, disp, result.config.coefficients)


def rls(
    y: np.ndarray,
    psi: np.ndarray,
    lam: float = 1.0,
    P0: float | np.ndarray = 1e6,
    theta0: np.ndarray | None = None,
    scales: np.ndarray | None = None,
    y_scale: float = 1.0,
) -> np.ndarray:
    """Eq. 16, recursive least squares with forgetting factor ``lam``, batched.

    ``y`` (B, N), ``psi`` (B, N, p) -> ``theta_hat`` (B, N, p), the estimate after each
    sample.  ``K_n = P psi / (lam + psi' P psi)``, ``theta_n = theta_{n-1} + K_n (y_n -
    psi' theta_{n-1})`` (the paper's ``theta_n`` in the innovation is a typo),
    ``P_n = (I - K_n psi') P_{n-1} / lam``.

    The recursion runs on the scaled problem ``psi / scales``, ``y / y_scale`` (the
    physical columns span 1e-12 .. 1); ``P0`` (scalar or (p, p)) and ``theta0`` are in
    those scaled units.  The returned estimates are in physical units.
    """
    y = np.asarray(y, dtype=np.float64)
    psi = np.asarray(psi, dtype=np.float64)
    if y.ndim == 1:
        y, psi = y[None], psi[None]
    p = psi.shape[2]
    scales = np.ones(p) if scales is None else np.asarray(scales, dtype=np.float64)
    if not (0 < lam <= 1):
        raise ValueError(f"lam must be in (0, 1]; got {lam!r}")
    p0 = np.asarray(P0, dtype=np.float64)
    p0 = p0 * np.eye(p) if p0.ndim == 0 else p0.copy()
    th0 = np.zeros(p) if theta0 is None else np.asarray(theta0, dtype=np.float64).copy()
    out = np.empty_like(psi)
    rls_batch_kernel(
        np.ascontiguousarray(y / y_scale), np.ascontiguousarray(psi / scales), float(lam),
        p0, th0, out,
    )
    return out * y_scale / scales


def batch_least_squares(
    y: np.ndarray,
    psi: np.ndarray,
    P0: float | np.ndarray | None = None,
    theta0: np.ndarray | None = None,
) -> np.ndarray:
    """Batch least squares ``argmin sum_n (y_n - psi_n' theta)^2`` per design -> (B, p).

    With ``P0`` the prior term ``(theta - theta0)' P0^-1 (theta - theta0)`` is added: the
    exact solution RLS with ``lam = 1`` reaches after the last sample (same units as the
    ``rls`` call's scaled problem).
    """
    y = np.asarray(y, dtype=np.float64)
    psi = np.asarray(psi, dtype=np.float64)
    if y.ndim == 1:
        y, psi = y[None], psi[None]
    p = psi.shape[2]
    out = np.empty((y.shape[0], p))
    for i in range(y.shape[0]):
        a, rhs = psi[i], y[i]
        if P0 is not None:
            p0 = np.asarray(P0, dtype=np.float64)
            p0 = p0 * np.eye(p) if p0.ndim == 0 else p0
            th0 = np.zeros(p) if theta0 is None else np.asarray(theta0, dtype=np.float64)
            root = np.linalg.cholesky(np.linalg.inv(p0))  # P0^-1 = L L'
            a = np.vstack([a, root.T])
            rhs = np.concatenate([rhs, root.T @ th0])
        out[i] = np.linalg.lstsq(a, rhs, rcond=None)[0]
    return out
