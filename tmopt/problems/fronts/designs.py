"""Designs that produce given front points: the check that a computed front is attained.

For a front point with position parameters and distance value ``g`` (see
:class:`~tmopt.problems.fronts.sampling.FrontSample`), these functions build a decision
vector whose *real* evaluation by the problem returns that point. The tests and
``experiments/check_fronts.py`` evaluate these designs with pymoo's problems and check
that the objectives match the front and every constraint holds, which validates the
whole construction (parametrisation, constraints in objective space, distance values)
against the problem code itself.

Distance values above the minimum are spread evenly over the distance variables: each
variable gets the same term of the sum that makes up ``g``, found by bisection on the
stretch where that term grows monotonically with the variable's offset.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def _invert(term: Callable[[np.ndarray], np.ndarray], target: np.ndarray, hi: float,
            n_iter: int = 60) -> np.ndarray:
    """Offsets ``d`` in [0, hi] with ``term(d) = target`` (``term`` increasing there)."""
    target = np.asarray(target, dtype=float)
    if np.any(target > term(np.array([hi]))[0] + 1e-12):
        raise ValueError("distance value too large for this number of variables")
    lo, up = np.zeros_like(target), np.full_like(target, hi)
    for _ in range(n_iter):
        mid = 0.5 * (lo + up)
        below = term(mid) < target
        lo, up = np.where(below, mid, lo), np.where(below, up, mid)
    return 0.5 * (lo + up)


def _away(centre: np.ndarray, offset: np.ndarray, xl: float, xu: float) -> np.ndarray:
    """``centre - offset`` where that stays in bounds, else ``centre + offset``."""
    return np.where(centre - offset >= xl, centre - offset, centre + offset).clip(xl, xu)


# ---- MW (pymoo's mw.py distance functions g1, g2, g3) -----------------------------------
def _mw_distance(kind: int, first: np.ndarray, g: np.ndarray, n_var: int, n_obj: int,
                 xu: float) -> np.ndarray:
    """Distance variables x_{M-1..D-1} (0-based) giving ``g`` (>= 1) per row."""
    d, m = n_var, n_var - n_obj + 1
    i = np.arange(n_obj - 1, d)[None, :]
    tau = ((g - 1.0) / m)[:, None] * np.ones((1, m))
    if kind == 1:  # 1 - exp(-10 (x^n - c_i)^2), c_i = 0.5 + i / (2d)
        c = 0.5 + i / (2 * d)
        z = c - np.sqrt(-np.log(1 - tau) / 10)
        return z ** (1.0 / (d - n_obj))
    if kind == 2:  # (0.1/d) z^2 + 1.5 - 1.5 cos(2 pi z), z = 1 - exp(-10 (x - i/d)^2)
        z = _invert(lambda z: 0.1 / d * z ** 2 + 1.5 - 1.5 * np.cos(2 * np.pi * z), tau, 0.5)
        return _away(np.broadcast_to(i / d, z.shape), np.sqrt(-np.log(1 - z) / 10), 0.0, xu)
    # kind 3: 2 (x_i + (x_{i-1} - 0.5)^2 - 1)^2 along a chain; only the last term moves.
    X = np.empty((len(g), m))
    prev = first
    for j in range(m):
        X[:, j] = 1 - (prev - 0.5) ** 2
        prev = X[:, j]
    X[:, -1] -= np.sqrt((g - 1.0) / 2)
    return X


#: MW k -> distance function (1: g1, 2: g2, 3: g3), as in Ma & Wang 2019.
MW_DISTANCE = {1: 1, 2: 2, 3: 3, 4: 1, 5: 1, 6: 2, 7: 3, 8: 2, 9: 1, 10: 2, 11: 3, 12: 1,
               13: 2, 14: 3}


def _simplex_position(F: np.ndarray) -> np.ndarray:
    """x with ``f_{M-1-j} / sum_{i <= M-1-j} f_i = x_j`` (MW4's simplex mapping)."""
    M = F.shape[1]
    cum = np.cumsum(F, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.column_stack([F[:, M - 1 - j] / cum[:, M - 1 - j] for j in range(M - 1)])
    return np.nan_to_num(x)


def _sphere_angles(F: np.ndarray) -> np.ndarray:
    """theta with ``f_{M-1-j} = ||f_{0..M-1-j}|| sin(theta_j)`` (DTLZ2 / MW8 mapping)."""
    M = F.shape[1]
    norms = np.sqrt(np.cumsum(F ** 2, axis=1))
    return np.column_stack([np.arctan2(F[:, M - 1 - j], norms[:, M - 2 - j])
                            for j in range(M - 1)])


def mw_designs(k: int, n_var: int, n_obj: int, xu: float, sample) -> np.ndarray:
    """Designs of MW``k`` (pymoo's variable bounds [0, xu]) for a front sample."""
    F, g = sample.F, sample.g
    if n_obj == 2:
        pos = sample.pos[:, 0]
        pos = pos ** (1.0 / n_var) if k == 10 else pos
        P = pos[:, None]
    elif k == 4:
        P = _simplex_position(F)
    elif k == 8:
        P = _sphere_angles(F) * 2 / np.pi
    else:  # MW14: the first M-1 objectives are the variables
        P = F[:, :-1]
    dist = _mw_distance(MW_DISTANCE[k], P[:, -1], g, n_var, n_obj, xu)
    return np.column_stack([P, dist])


# ---- C-DTLZ (pymoo's dtlz.py: DTLZ1 and DTLZ3 use g1, DTLZ2 and DTLZ4 use g2) -----------
def cdtlz_designs(name: str, n_var: int, F: np.ndarray, alpha: float = 100.0) -> np.ndarray:
    """Designs of a C-DTLZ problem producing the objective vectors ``F``."""
    M = F.shape[1]
    k = n_var - M + 1
    if name.endswith("dtlz1"):
        g = 2 * F.sum(1) - 1
        P = _dtlz1_position(F)
    else:
        g = np.linalg.norm(F, axis=1) - 1
        P = _sphere_angles(F) * 2 / np.pi
        if name.endswith("dtlz4"):
            P = P ** (1.0 / alpha)
    if name in ("c1dtlz1", "c3dtlz1", "c1dtlz3"):  # g1 = 100 sum(d^2 + 1 - cos(20 pi d))
        tau = np.maximum(g, 0)[:, None] / (100 * k) * np.ones((1, k))
        dist = 0.5 + _invert(lambda d: d ** 2 + 1 - np.cos(20 * np.pi * d), tau, 0.05)
    else:  # g2 = sum (x - 0.5)^2
        dist = 0.5 + np.sqrt(np.maximum(g, 0) / k)[:, None] * np.ones((1, k))
    return np.column_stack([P, dist])


def _dtlz1_position(F: np.ndarray) -> np.ndarray:
    """x with ``f_{M-1-j} / sum_{i <= M-1-j} f_i = 1 - x_j`` (DTLZ1 mapping)."""
    return 1 - _simplex_position(F)


# ---- DAS-CMOP (pymoo's dascmop.py distance functions) -----------------------------------
def dascmop_designs(k: int, n_var: int, sample) -> np.ndarray:
    """Designs of DAS-CMOP``k`` with ``n_var`` variables for a front sample."""
    P, g = sample.pos, sample.g
    M = P.shape[1] + 1
    m = n_var - M + 1
    if k in (1, 2, 3):  # sum (x_i - sin(pi x_1 / 2))^2
        centre = np.sin(0.5 * np.pi * P[:, :1]) * np.ones((1, m))
        dist = _away(centre, np.sqrt(g / m)[:, None], 0.0, 1.0)
    elif k == 9:  # sum (x_j - cos(0.25 j / n pi (x_1 + x_2)))^2, j = M..n
        j = np.arange(M - 1, n_var)[None, :] + 1
        centre = np.cos(0.25 * j / n_var * np.pi * (P[:, :1] + P[:, 1:2]))
        dist = _away(centre, np.sqrt(g / m)[:, None], 0.0, 1.0)
    else:  # (n - M + 1) + sum (z^2 - cos(20 pi z)), z = x - 0.5
        tau = (g / m)[:, None] * np.ones((1, m))
        dist = 0.5 + _invert(lambda z: z ** 2 + 1 - np.cos(20 * np.pi * z), tau, 0.05)
    return np.column_stack([P, dist])


# ---- LIR-CMOP (tmopt.problems.lircmop) ---------------------------------------------------
def lircmop_designs(k: int, n_var: int, sample) -> np.ndarray:
    """Designs of LIR-CMOP``k`` with ``n_var`` variables for a front sample: every
    distance variable of a sum moved off its centre by the same amount."""
    from tmopt.problems.lircmop import centres

    n = len(sample.F)
    X = np.empty((n, n_var))
    if k >= 13:  # x1, x2 on the sphere; 10 sum (x_j - 0.5)^2 = g over j >= 3
        X[:, :2] = sample.pos
        delta = np.sqrt(sample.g / (10 * (n_var - 2)))[:, None]
        X[:, 2:] = 0.5 + delta * np.ones((1, n_var - 2))
        return X
    t, g1, g2 = sample.pos.T
    X[:, 0] = t
    c_odd, c_even = centres(k, t, n_var)
    X[:, 2::2] = _away(c_odd, np.sqrt(g1 / c_odd.shape[1])[:, None], 0.0, 1.0)
    X[:, 1::2] = _away(c_even, np.sqrt(g2 / c_even.shape[1])[:, None], 0.0, 1.0)
    return X
