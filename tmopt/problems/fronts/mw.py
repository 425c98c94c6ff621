"""Offline Pareto fronts of the MW suite (Ma & Wang, IEEE TEVC 23(6):972-986, 2019).

Every MW problem is ``F = g * B(x_1..x_{M-1})`` (MW4-14) or ``F = (x_1, g - c x_1)``
(MW1-3) with ``g >= 1`` a distance function whose minimum 1 is attained, and constraints
that depend on ``F`` only. The front is therefore found in objective space (module
:mod:`~tmopt.problems.fronts.sampling`): sample the unconstrained front ``B`` (``g = 1``)
densely, move every point outwards to its lowest feasible ``g`` and keep the
non-dominated points. Where the lowest feasible ``g`` is 1 everywhere (MW2, MW4, MW14)
the front is the closed-form curve or surface itself (MW8: the sphere minus infeasible
bands). MW5's front holds 16 isolated points known in closed form plus short arcs next
to them; MW11 has one isolated feasible point, (1, 1), that no grid hits.

The constraint functions below restate those of the problems (pymoo's ``mw.py``, after
Ma & Wang's C++ code) as functions of ``F``; ``tests/problems/test_fronts.py`` checks
that they equal the problems' own ``G`` on random designs.
"""

from __future__ import annotations

import numpy as np

from tmopt.problems.fronts.sampling import (
    FrontSample,
    even_along,
    lowest_feasible_curve,
    nondominated,
    nondominated_index,
    simplex_points,
    sphere_points,
    thin_curve,
)

SQ2 = np.sqrt(2.0)


def _angle(F: np.ndarray) -> np.ndarray:
    """atan(f2 / f1) in [0, pi/2] (pi/2 where f1 = 0, as the C code's atan(inf))."""
    return np.arctan2(F[:, 1], F[:, 0])


# ---- constraints in objective space, G <= 0 feasible (Ma & Wang 2019, Table I) --------
def _g_mw1(F):
    l = SQ2 * (F[:, 1] - F[:, 0])
    return (F.sum(1) - 1 - 0.5 * np.sin(2 * np.pi * l) ** 8)[:, None]


def _g_mw2(F):
    l = SQ2 * (F[:, 1] - F[:, 0])
    return (F.sum(1) - 1 - 0.5 * np.sin(3 * np.pi * l) ** 8)[:, None]


def _g_mw3(F):
    l = SQ2 * (F[:, 1] - F[:, 0])
    s = F.sum(1)
    return np.column_stack([s - 1.05 - 0.45 * np.sin(0.75 * np.pi * l) ** 6,
                            0.85 - s + 0.3 * np.sin(0.75 * np.pi * l) ** 2])


def _g_mw4(F):
    l = F[:, -1] - F[:, :-1].sum(1)
    return (F.sum(1) - 1 - 0.4 * np.sin(2.5 * np.pi * l) ** 8)[:, None]


def _g_mw5(F):
    l1 = _angle(F)
    l2 = 0.5 * np.pi - 2 * np.abs(l1 - 0.25 * np.pi)
    r2 = (F ** 2).sum(1)
    return np.column_stack([r2 - (1.7 - 0.2 * np.sin(2 * l1)) ** 2,
                            (1 + 0.5 * np.sin(6 * l2 ** 3)) ** 2 - r2,
                            (1 - 0.45 * np.sin(6 * l2 ** 3)) ** 2 - r2])


def _g_mw6(F):
    l = np.cos(6 * _angle(F) ** 4) ** 10
    return ((F[:, 0] / (1 + 0.15 * l)) ** 2 + (F[:, 1] / (1 + 0.75 * l)) ** 2 - 1)[:, None]


def _g_mw7(F):
    l = _angle(F)
    r2 = (F ** 2).sum(1)
    return np.column_stack([r2 - (1.2 + np.abs(0.4 * np.sin(4 * l) ** 16)) ** 2,
                            (1.15 - 0.2 * np.sin(4 * l) ** 8) ** 2 - r2])


def _g_mw8(F):
    r2 = (F ** 2).sum(1)
    l = np.arcsin(np.clip(F[:, -1] / np.sqrt(r2), -1, 1))
    return (r2 - (1.25 - 0.5 * np.sin(6 * l) ** 2) ** 2)[:, None]


def _g_mw9(F):
    f1, f2 = F[:, 0], F[:, 1]
    t1 = (1 - 0.64 * f1 ** 2 - f2) * (1 - 0.36 * f1 ** 2 - f2)
    t2 = (1.35 ** 2 - (f1 + 0.35) ** 2 - f2) * (1.15 ** 2 - (f1 + 0.15) ** 2 - f2)
    return np.minimum(t1, t2)[:, None]


def _g_mw10(F):
    a, f2 = F[:, 0] ** 2, F[:, 1]
    return np.column_stack([-(2 - 4 * a - f2) * (2 - 8 * a - f2),
                            (2 - 2 * a - f2) * (2 - 16 * a - f2),
                            (1 - a - f2) * (1.2 - 1.2 * a - f2)])


def _g_mw11(F):
    a, f2 = F[:, 0] ** 2, F[:, 1]
    return np.column_stack([-(3 - a - f2) * (3 - 2 * a - f2),
                            (3 - 0.625 * a - f2) * (3 - 7 * a - f2),
                            -(1.62 - 0.18 * a - f2) * (1.125 - 0.125 * a - f2),
                            (2.07 - 0.23 * a - f2) * (0.63 - 0.07 * a - f2)])


def _g_mw12(F):
    f1, f2 = F[:, 0], F[:, 1]
    s = np.sin
    c1 = -((1 - 0.625 * f1 - f2 + 0.08 * s(2 * np.pi * (f2 - f1 / 1.6)))
           * (1.4 - 0.875 * f1 - f2 + 0.08 * s(2 * np.pi * (f2 / 1.4 - f1 / 1.6))))
    c2 = ((1 - 0.8 * f1 - f2 + 0.08 * s(2 * np.pi * (f2 - f1 / 1.5)))
          * (1.8 - 1.125 * f1 - f2 + 0.08 * s(2 * np.pi * (f2 / 1.8 - f1 / 1.6))))
    return np.column_stack([c1, c2])


def _g_mw13(F):
    f1, f2 = F[:, 0], F[:, 1]
    w = 0.5 * np.sin(3 * np.pi * f1)
    c1 = -(5 - (1 + f1 + 0.5 * f1 ** 2) - w - f2) * (5 - (1 + 0.7 * f1) - w - f2)
    c2 = (5 - np.exp(f1) - w - f2) * (5 - (1 + 0.4 * f1) - w - f2)
    return np.column_stack([c1, c2])


def _g_mw14(F):
    x = F[:, :-1]
    alpha = 6.1 - 1 - x - 0.5 * x ** 2 - 1.5 * np.sin(1.1 * np.pi * x ** 2)
    return (F[:, -1] - alpha.sum(1) / x.shape[1])[:, None]


CONSTRAINTS = {1: _g_mw1, 2: _g_mw2, 3: _g_mw3, 4: _g_mw4, 5: _g_mw5, 6: _g_mw6, 7: _g_mw7,
               8: _g_mw8, 9: _g_mw9, 10: _g_mw10, 11: _g_mw11, 12: _g_mw12, 13: _g_mw13,
               14: _g_mw14}


def constraints(k: int, F: np.ndarray) -> np.ndarray:
    """Constraint values ``G`` (n, n_constr) of MW``k`` at objective vectors ``F``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return CONSTRAINTS[k](np.atleast_2d(np.asarray(F, dtype=float)))


def violation(k: int):
    """(n, M) objective vectors -> (n,) largest constraint value of MW``k``."""
    return lambda F: constraints(k, F).max(axis=1)


# ---- the unconstrained fronts B(t) (g = 1) of the bi-objective problems -----------------
#: k -> (t range, B(t), shift direction or None for scaling, largest move searched).
_CURVES = {
    1: ((0.0, 1.0), lambda t: (t, 1 - 0.85 * t), (0.0, 1.0), 1.5),
    2: ((0.0, 1.0), lambda t: (t, 1 - t), (0.0, 1.0), 1.5),
    3: ((0.0, 1.0), lambda t: (t, 1 - t), (0.0, 1.0), 1.5),
    5: ((0.0, 1.0), lambda t: (t, np.sqrt(np.maximum(1 - t ** 2, 0))), None, 2.0),
    6: ((0.0, 1.1), lambda t: (t, np.sqrt(np.maximum(1.21 - t ** 2, 0))), None, 2.0),
    7: ((0.0, 1.0), lambda t: (t, np.sqrt(np.maximum(1 - t ** 2, 0))), None, 2.0),
    9: ((0.0, 1.0), lambda t: (t, 1 - t ** 0.6), None, 2.0),
    10: ((0.0, 1.0), lambda t: (t, 1 - t ** 2), None, 2.0),
    11: ((0.0, SQ2), lambda t: (t, np.sqrt(np.maximum(2 - t ** 2, 0))), None, 2.0),
    12: ((0.0, 1.0), lambda t: (t, 0.85 - 0.8 * t - 0.08 * np.abs(np.sin(3.2 * np.pi * t))),
         None, 2.0),
    13: ((0.0, 1.5), lambda t: (t, 5 - np.exp(t) - 0.5 * np.abs(np.sin(3 * np.pi * t))),
         None, 2.0),
}


def mw5_isolated_points() -> np.ndarray:
    """The 16 points of MW5's front on the unit circle (``g = 1``), in closed form.

    With ``l2 = pi/2 - 2 |l1 - pi/4|`` and ``l1`` the polar angle, constraints 2 and 3 hold
    together on ``g = 1`` only where ``sin(6 l2^3) = 0``, i.e. ``l2 = (k pi / 6)^(1/3)``,
    k = 0..7, at the angles ``l1 = pi/4 +- (pi/2 - l2) / 2``. PlatEMO's MW5 front is these
    16 points; next to each, the lowest feasible ``g`` grows only like the cube of the
    angle, so short arcs just outside the circle are non-dominated too and belong to the
    front computed here.
    """
    l2 = (np.arange(8) * np.pi / 6.0) ** (1.0 / 3.0)
    half = 0.5 * (0.5 * np.pi - l2)
    l1 = np.concatenate([0.25 * np.pi - half, 0.25 * np.pi + half])
    return nondominated(np.column_stack([np.cos(l1), np.sin(l1)]))


#: Feasible points of g = 1 that are isolated in t, so a grid would miss them.
_SPECIAL_T = {
    5: lambda: mw5_isolated_points()[:, 0],
    11: lambda: np.array([1.0]),  # (1, 1): constraints 1 and 3 both active, cf. PlatEMO
}


def _curve_front(k: int, n_points: int) -> FrontSample:
    (lo, hi), curve, shift, s_max = _CURVES[k]
    base = lambda u: np.column_stack(curve(u))  # noqa: E731
    # Twice the points wanted, evenly along the curve, then thinned evenly along the front;
    # MW5's front is short arcs around 16 points: four times.
    t = even_along(base, lo, hi, n_points * (4 if k == 5 else 2))
    if k in _SPECIAL_T:
        t = np.union1d(t, _SPECIAL_T[k]())
    shift = None if shift is None else np.asarray(shift, dtype=float)
    F, t, s = lowest_feasible_curve(base, t, violation(k), s_max, shift, n_grid=1000)
    # MW1-3: f2 = g - c f1 with g = 1 + s; MW4-14: F = g B(t) with g = s.
    sample = FrontSample(F, t[:, None], s + 1.0 if shift is not None else s)
    nd = nondominated_index(F)
    sample = sample.take(nd[np.argsort(F[nd, 0], kind="stable")])
    return sample.take(thin_curve(sample.F, n_points))


def mw4_front(n_obj: int, n_points: int) -> FrontSample:
    """MW4: the simplex sum f = 1 (its constraint holds there everywhere)."""
    W = simplex_points(n_obj, n_points)
    return FrontSample(W, W[:, :-1], np.ones(len(W)))


def mw8_front(n_obj: int, n_points: int) -> FrontSample:
    """MW8: the unit sphere where ``sin(6 asin(f_M))^2 <= 1/2``.

    On the sphere the constraint reads ``1 <= (1.25 - 0.5 sin^2(6 l))^2``; where it fails,
    the bound on the radius is below 1 for every radius, so no outward point is feasible
    either: the gaps stay empty.
    """
    U = sphere_points(n_obj, n_points)
    U = U[violation(8)(U) <= 0.0]
    return FrontSample(U, U[:, :-1], np.ones(len(U)))


def mw14_front(n_obj: int, n_points: int) -> FrontSample:
    """MW14: ``f_M = mean_j h(f_j)``, ``h(x) = 6 - e^x - 1.5 sin(1.1 pi x^2)``, f_j in [0, 1.5].

    ``f_M`` is a sum of one-dimensional terms, so a point is non-dominated exactly when
    every ``(f_j, h(f_j))`` is non-dominated on the curve ``(x, h(x))``; those ``x`` form
    two intervals (about [0, 0.731] and [1.331, 1.5], cf. PlatEMO), found here on a fine
    grid and sampled evenly, ends included. The constraint holds on the whole ``g = 1``
    surface (tested).
    """
    x = np.linspace(0.0, 1.5, 15001)
    h = 6 - np.exp(x) - 1.5 * np.sin(1.1 * np.pi * x ** 2)
    keep = h < np.concatenate([[np.inf], np.minimum.accumulate(h[:-1])])
    per_axis = max(int(round(n_points ** (1.0 / (n_obj - 1)))), 4)
    xs = _even_in_runs(x, keep, per_axis)
    grid = np.stack(np.meshgrid(*[xs] * (n_obj - 1), indexing="ij"), -1).reshape(-1, n_obj - 1)
    last = (6 - np.exp(grid) - 1.5 * np.sin(1.1 * np.pi * grid ** 2)).mean(1)
    return FrontSample(np.column_stack([grid, last]), grid, np.ones(len(grid)))


def _even_in_runs(x: np.ndarray, keep: np.ndarray, n: int) -> np.ndarray:
    """About n values spread over the runs of ``x[keep]`` in proportion to their lengths."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(int), [0]])))
    runs = [(x[a], x[b - 1]) for a, b in zip(edges[::2], edges[1::2])]
    total = sum(hi - lo for lo, hi in runs)
    parts = [np.linspace(lo, hi, max(2, int(round(n * (hi - lo) / total)))) for lo, hi in runs]
    return np.concatenate(parts)


def front_sample(k: int, n_obj: int = 2, n_points: int = 2000) -> FrontSample:
    """Front of MW``k`` with the position ``t`` and distance ``g`` of every point."""
    if not 1 <= k <= 14:
        raise ValueError(f"MW problem number must be in 1..14, got {k}")
    if k == 4:
        return mw4_front(n_obj, n_points)
    if k == 8:
        return mw8_front(n_obj, n_points)
    if k == 14:
        return mw14_front(n_obj, n_points)
    return _curve_front(k, n_points)


def front(k: int, n_obj: int = 2, n_points: int = 2000) -> np.ndarray:
    """Pareto front of MW``k`` (rows of objective vectors), computed offline."""
    return front_sample(k, n_obj, n_points).F
