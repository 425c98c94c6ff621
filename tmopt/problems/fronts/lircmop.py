"""Offline Pareto fronts of LIR-CMOP1-14 (Fan et al., Soft Computing 23, 2019).

How each is obtained (:mod:`tmopt.problems.lircmop` has the definitions):

* **LIR-CMOP1-4, analytic.** The constraints hold only for ``g1, g2 in [0.5, 0.51]``, so
  the front is the unconstrained curve moved by 0.5: ``(t + 0.5, 1 - h(t) + 0.5)``,
  for LIR-CMOP3-4 only where ``sin(20 pi t) >= 0.5`` (the pieces' ends exactly).
* **LIR-CMOP13-14, analytic.** ``|F| = 1.7057 + g`` and the constraints are bands of
  ``|F|``: the front is the eighth of the sphere of the smallest feasible radius,
  1.7057 (13) or 1.75 (14: the band 1.6 < |F| < 1.75 is infeasible).
* **LIR-CMOP5-12, sampled from the boundary of the feasible region.** The distance
  sums enter the two objectives independently, so the attainable objective vectors are
  the whole region ``A`` above the unconstrained curve ``c(t)`` (plus the rays above its
  ends); the constraints, all in objective space, cut ellipses (and, 9-12, the region
  below a wavy line) out of it. Non-dominated points of a closed set lie on its
  boundary, so the front is the non-dominated subset of the boundary of ``A`` minus the
  cuts: the curve, the two rays and the constraints' zero sets (parametrised exactly)
  where they lie in ``A`` and satisfy every other constraint. PlatEMO instead filters
  the curve (5, 6, 9, 10), walks outwards along rays (7, 8) or lists points (11, 12);
  the tests check that its points lie on these fronts.
"""

from __future__ import annotations

import numpy as np

from tmopt.problems import lircmop as lir
from tmopt.problems.fronts.sampling import (
    FrontSample,
    even_along,
    nondominated_index,
    sphere_points,
    thin_curve,
)

#: Boundary samples per curve, ray and constraint zero set of LIR-CMOP5-12.
N_BOUNDARY = 40_000
#: Largest constraint value counted as feasible for points computed on a boundary.
FEASIBLE_TOL = 1e-12
#: Smallest feasible |F| of LIR-CMOP13-14.
SPHERE_RADIUS = {13: lir.RADIUS, 14: 1.75}


def curve(k: int, t: np.ndarray) -> np.ndarray:
    """Unconstrained front ``c(t)`` of the 2-objective LIR-CMOP``k`` (distance sums 0)."""
    t = np.asarray(t, dtype=float)
    if k <= 4:
        return np.column_stack([t + 0.5, 1 - lir.h(k, t) + 0.5])
    if k <= 8:
        return np.column_stack([t, 1 - lir.h(k, t)]) + lir.OFFSET
    return lir.RADIUS * np.column_stack([t, 1 - lir.h(k, t)])


def _pieces_lir34(n: int) -> np.ndarray:
    """About n values of t in [0, 1] with sin(20 pi t) >= 0.5, every piece's ends included."""
    starts = (1 / 6 + 2 * np.arange(10)) / 20
    ends = (5 / 6 + 2 * np.arange(10)) / 20
    per = max(n // 10, 2)
    return np.concatenate([np.linspace(a, b, per) for a, b in zip(starts, ends)])


def front_sample(k: int, n_points: int = 2000) -> FrontSample:
    """Front of LIR-CMOP``k`` with, per point, the variables behind it.

    ``pos``: 2 objectives: ``(x1, g1, g2)``, the position and both distance sums;
    3 objectives: ``(x1, x2)``. ``g``: ``g1 + g2`` (2 objectives) or the distance sum.
    """
    if not 1 <= k <= 14:
        raise ValueError(f"LIR-CMOP problem number must be in 1..14, got {k}")
    if k >= 13:
        F = SPHERE_RADIUS[k] * sphere_points(3, n_points)
        x1 = np.arcsin(np.clip(F[:, 2] / SPHERE_RADIUS[k], -1, 1)) * 2 / np.pi
        x2 = np.arctan2(F[:, 1], F[:, 0]) * 2 / np.pi
        return FrontSample(F, np.column_stack([x1, x2]),
                           np.full(len(F), SPHERE_RADIUS[k] - lir.RADIUS))
    if k <= 4:
        t = _pieces_lir34(n_points) if k >= 3 else even_along(
            lambda u: curve(k, u), 0.0, 1.0, n_points)
        F = curve(k, t)
        pos = np.column_stack([t, np.full_like(t, 0.5), np.full_like(t, 0.5)])
        return FrontSample(F, pos, np.ones_like(t))
    F = _boundary_front(k)
    F = F[thin_curve(F, n_points)]
    pos = distances(k, F)
    return FrontSample(F, pos, pos[:, 1] + pos[:, 2])


def _boundary_parts(k: int) -> list[tuple]:
    """The boundary of LIR-CMOP``k``'s attainable region and of its constraints as
    parametric curves ``(function of u -> (n, 2) points, u grid)``."""
    n = N_BOUNDARY
    c0, c1 = curve(k, np.array([0.0, 1.0]))
    parts = [(lambda u: curve(k, u), even_along(lambda u: curve(k, u), 0.0, 1.0, n)),
             (lambda s: c0 + s[:, None] * [0.0, 1.0], np.linspace(0.0, 4.0, n)),
             (lambda s: c1 + s[:, None] * [1.0, 0.0], np.linspace(0.0, 4.0, n))]
    cos_t, sin_t = np.cos(lir.THETA), np.sin(lir.THETA)
    for p, q, a, b in lir._ELLIPSES[k]:  # r - u^2/a^2 - v^2/b^2 = 0, rotated back
        def ellipse(phi, p=p, q=q, a=a, b=b):
            u = a * np.sqrt(lir.ELLIPSE_R) * np.cos(phi)
            v = b * np.sqrt(lir.ELLIPSE_R) * np.sin(phi)
            return np.column_stack([p + u * cos_t + v * sin_t, q - u * sin_t + v * cos_t])
        parts.append((ellipse, np.linspace(0.0, 2 * np.pi, n)))
    if k in lir._WAVE:  # z = c + sin(4 pi w), (w, z) the coordinates rotated by alpha
        ca, sa = np.cos(lir.ALPHA), np.sin(lir.ALPHA)

        def wave(w):
            z = lir._WAVE[k] + np.sin(4 * np.pi * w)
            return np.column_stack([w * ca + z * sa, -w * sa + z * ca])
        parts.append((wave, np.linspace(-4.0, 4.0, 8 * n)))
    return parts


def _feasible(k: int, F: np.ndarray) -> np.ndarray:
    return in_region(k, F) & (lir.objective_constraints(k, F).max(axis=1) <= FEASIBLE_TOL)


def _boundary_front(k: int, n_bisect: int = 60) -> np.ndarray:
    """Non-dominated feasible points of the boundary of LIR-CMOP``k`` (5..12), sorted by
    f1. Where feasibility changes between two samples of a boundary curve, the change
    is located by bisection, so every feasible arc's ends are points of the front
    candidates (not only the samples next to them)."""
    found = []
    for fun, u in _boundary_parts(k):
        F = fun(u)
        ok = _feasible(k, F)
        found.append(F[ok])
        flip = np.flatnonzero(ok[:-1] != ok[1:])
        lo, hi = u[flip], u[flip + 1]
        good_lo = ok[flip]  # whether the lower end of each interval is the feasible one
        for _ in range(n_bisect):
            mid = 0.5 * (lo + hi)
            like_lo = _feasible(k, fun(mid)) == good_lo
            lo, hi = np.where(like_lo, mid, lo), np.where(like_lo, hi, mid)
        ends = np.where(good_lo, lo, hi)
        E = fun(ends)
        found.append(E[_feasible(k, E)])
    F = _onto_region(k, np.vstack(found))
    nd = nondominated_index(F)
    return F[nd[np.argsort(F[nd, 0], kind="stable")]]


def _onto_region(k: int, F: np.ndarray) -> np.ndarray:
    """Points within the tolerance outside the attainable region moved onto its edge: a
    point 1e-12 left of ``f1 = c1(0)`` (an ellipse's end on the vertical ray) would
    otherwise be non-dominated only because no attainable point is that far left."""
    lo = curve(k, np.array([0.0]))[0, 0]
    scale = 1.0 if k <= 8 else lir.RADIUS
    F = F.copy()
    F[:, 0] = np.maximum(F[:, 0], lo)
    t_star = np.clip((F[:, 0] - lo) / scale, 0.0, 1.0)
    F[:, 1] = np.maximum(F[:, 1], curve(k, t_star)[:, 1])
    return F


def in_region(k: int, F: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    """Whether each row of ``F`` is attainable by LIR-CMOP``k`` (5..12): on or above the
    curve, i.e. ``f2 >= c2(t*)`` at the largest ``t*`` with ``c1(t*) <= f1``."""
    lo = curve(k, np.array([0.0]))[0, 0]
    scale = 1.0 if k <= 8 else lir.RADIUS
    t_star = np.clip((F[:, 0] - lo) / scale, 0.0, 1.0)
    return (F[:, 0] >= lo - tol) & (F[:, 1] >= curve(k, t_star)[:, 1] - tol)


def distances(k: int, F: np.ndarray, n_bisect: int = 60) -> np.ndarray:
    """``(x1, g1, g2)`` with which LIR-CMOP``k`` (5..12) attains each row of ``F``.

    A point of the region is reached from any ``t`` between the smallest ``t_lo`` with
    ``c2(t) <= f2`` and the largest ``t_hi`` with ``c1(t) <= f1``; g1 falls and g2 grows
    with ``t``, so ``t`` is taken where they are equal (bisection), which keeps both sums
    small enough for few variables to reach.
    """
    lo = curve(k, np.array([0.0]))[0, 0]
    off, scale = (lir.OFFSET, 1.0) if k <= 8 else (0.0, lir.RADIUS)
    t_hi = np.clip((F[:, 0] - lo) / scale, 0.0, 1.0)
    target = np.clip(1 - (F[:, 1] - off) / scale, 0.0, 1.0)  # h(t_lo)
    t_lo = np.minimum(target ** 2 if not lir.concave(k) else np.sqrt(target), t_hi)

    def sums(t):
        c = curve(k, t)
        if k <= 8:
            return (F[:, 0] - c[:, 0]) / 10, (F[:, 1] - c[:, 1]) / 10
        with np.errstate(divide="ignore", invalid="ignore"):
            g1 = np.where(c[:, 0] > 0, (F[:, 0] / c[:, 0] - 1) / 10, 0.0)
            g2 = np.where(c[:, 1] > 0, (F[:, 1] / c[:, 1] - 1) / 10, 0.0)
        return g1, g2

    a, b = t_lo.copy(), t_hi.copy()
    for _ in range(n_bisect):
        mid = 0.5 * (a + b)
        g1, g2 = sums(mid)
        a, b = np.where(g1 > g2, mid, a), np.where(g1 > g2, b, mid)
    t = 0.5 * (a + b)
    g1, g2 = sums(t)
    return np.column_stack([t, np.maximum(g1, 0.0), np.maximum(g2, 0.0)])


def design_grid(k: int, n_t: int = 400, n_s: int = 60, s_max: float = 0.12) -> np.ndarray:
    """Feasible objective vectors of LIR-CMOP``k`` (5..12) on a grid of (x1, g1, g2): for
    brute-force checks of the front (no boundary, no non-dominated filter)."""
    t = np.linspace(0, 1, n_t)
    s1, s2 = np.meshgrid(np.linspace(0, s_max, n_s), np.linspace(0, s_max, n_s))
    T = np.repeat(t, s1.size)
    S = 10 * np.column_stack([np.tile(s1.ravel(), n_t), np.tile(s2.ravel(), n_t)])
    c = curve(k, T)
    F = c + S if k <= 8 else c * (1 + S)
    return F[lir.objective_constraints(k, F).max(axis=1) <= 0]


def front(k: int, n_points: int = 2000) -> np.ndarray:
    """Pareto front of LIR-CMOP``k``, (n, M)."""
    return front_sample(k, n_points).F
