"""Offline Pareto fronts of DAS-CMOP1-9 (Fan et al., "Difficulty adjustable and scalable
constrained multiobjective test problem toolkit", Evolutionary Computation 28(3), 2020).

A DAS-CMOP problem reaches ``F = B(x_1[, x_2]) + g (1, ..., 1)`` with ``g >= 0`` and has
three constraint types whose strength is set by the difficulty triplet (eta, zeta, gamma):

* type I (diversity), on the position variables only: ``sin(20 pi x_1) >= 2 eta - 1``
  (and ``cos(20 pi x_2) >= 2 eta - 1`` for three objectives);
* type II (convergence), on g only: ``g`` in ``[d, e]`` with ``d = 0.5``,
  ``e = d - ln(zeta)`` (``zeta = 0``: ``g >= 0``; ``zeta = 1``: ``|g - 0.5| <= 1e-4``);
* type III (convergence and diversity), in objective space: outside ellipses (two
  objectives, semi-axes from 0.3 and 1.2, rotated by -pi/4) or spheres (three objectives)
  of size ``r = gamma / 2``.

So the front is the non-dominated subset of: for every position satisfying type I, the
lowest ``g`` allowed by type II, moved further along (1, ..., 1) until outside every
type-III region (:func:`~tmopt.problems.fronts.sampling.lowest_feasible`). The formulas
restate pymoo's ``dascmop.py``; the tests compare them with the problems' own ``G``.
"""

from __future__ import annotations

import numpy as np

from tmopt.problems.fronts.sampling import (
    FrontSample,
    even_along,
    lowest_feasible,
    lowest_feasible_curve,
    nondominated_index,
    thin_curve,
)

#: The 16 difficulty triplets (eta, zeta, gamma) of Fan et al. 2020, Table 2 (pymoo order).
DIFFICULTIES: tuple[tuple[float, float, float], ...] = (
    (0.25, 0.0, 0.0), (0.0, 0.25, 0.0), (0.0, 0.0, 0.25), (0.25, 0.25, 0.25),
    (0.5, 0.0, 0.0), (0.0, 0.5, 0.0), (0.0, 0.0, 0.5), (0.5, 0.5, 0.5),
    (0.75, 0.0, 0.0), (0.0, 0.75, 0.0), (0.0, 0.0, 0.75), (0.75, 0.75, 0.75),
    (0.0, 1.0, 0.0), (0.5, 1.0, 0.0), (0.0, 1.0, 0.5), (0.5, 1.0, 0.5),
)

_P = np.array([0.0, 1.0, 0.0, 1.0, 2.0, 0.0, 1.0, 2.0, 3.0])
_Q = np.array([1.5, 0.5, 2.5, 1.5, 0.5, 3.5, 2.5, 1.5, 0.5])
_CENTRES = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0],
                     np.full(3, 1 / np.sqrt(3.0))])


def triplet(difficulty) -> tuple[float, float, float]:
    """(eta, zeta, gamma) of a difficulty given as 1..16 or as a triplet in [0, 1]^3."""
    if isinstance(difficulty, (int, np.integer)) and not isinstance(difficulty, bool):
        if not 1 <= difficulty <= len(DIFFICULTIES):
            raise ValueError(f"DAS-CMOP difficulty must be an integer in 1..16 or a triplet "
                             f"(eta, zeta, gamma) in [0, 1], got {difficulty!r}")
        return DIFFICULTIES[difficulty - 1]
    vals = tuple(float(v) for v in difficulty)
    if len(vals) != 3 or not all(0.0 <= v <= 1.0 for v in vals):
        raise ValueError(f"DAS-CMOP difficulty triplet (eta, zeta, gamma) must have three "
                         f"values in [0, 1], got {difficulty!r}")
    return vals  # type: ignore[return-value]


def g_range(zeta: float) -> tuple[float, float]:
    """The values of g allowed by the type-II constraint ``(e - g)(g - d) >= 0``."""
    if zeta == 0.0:
        return 0.0, np.inf
    if zeta == 1.0:
        return 0.5 - 1e-4, 0.5 + 1e-4
    return 0.5, 0.5 - np.log(zeta)


def type3(F: np.ndarray, gamma: float) -> np.ndarray:
    """Type-III constraints in objective space, ``G <= 0`` feasible (outside the regions)."""
    r = 0.5 * gamma
    if F.shape[1] == 2:
        c, s = np.cos(-0.25 * np.pi), np.sin(-0.25 * np.pi)
        u = (F[:, :1] - _P) * c - (F[:, 1:] - _Q) * s
        v = (F[:, :1] - _P) * s + (F[:, 1:] - _Q) * c
        return r - (u ** 2 / 0.3 + v ** 2 / 1.2)
    return r ** 2 - ((F[:, None, :] - _CENTRES[None]) ** 2).sum(2)


def _base2(k: int, t: np.ndarray) -> np.ndarray:
    h = {1: 1 - t ** 2, 2: 1 - np.sqrt(t), 3: 1 - np.sqrt(t) + 0.5 * np.abs(np.sin(5 * np.pi * t))}
    return np.column_stack([t, h[(k - 1) % 3 + 1]])


def _base3(k: int, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    if k == 7:
        return np.column_stack([x1 * x2, x2 * (1 - x1), 1 - x2])
    c1 = np.cos(0.5 * np.pi * x1)
    return np.column_stack([c1 * np.cos(0.5 * np.pi * x2), c1 * np.sin(0.5 * np.pi * x2),
                            np.sin(0.5 * np.pi * x1)])


def _type1_values(n: int, b: float, use_cos: bool = False) -> np.ndarray:
    """About n evenly spread x in [0, 1] with sin(20 pi x) >= b (cos for ``use_cos``)."""
    x = np.linspace(0.0, 1.0, 40 * n + 1)
    ok = (np.cos if use_cos else np.sin)(20 * np.pi * x) >= b
    keep = x[ok]
    return keep[np.unique(np.round(np.linspace(0, len(keep) - 1, n)).astype(int))]


def front_sample(k: int, difficulty=8, n_points: int = 2000) -> FrontSample:
    """Front of DAS-CMOP``k`` with the position variables and the g of every point."""
    if not 1 <= k <= 9:
        raise ValueError(f"DAS-CMOP problem number must be in 1..9, got {k}")
    eta, zeta, gamma = triplet(difficulty)
    b = 2 * eta - 1
    g_lo, g_hi = g_range(zeta)
    violation = lambda F: type3(F, gamma).max(axis=1)  # noqa: E731
    span, shift = min(g_hi - g_lo, 3.0), np.ones(2 if k <= 6 else 3)
    if k <= 6:
        def curve(t):  # type-I infeasible positions become NaN rows, i.e. infeasible
            base = _base2(k, t) + g_lo
            base[np.sin(20 * np.pi * t) < b] = np.nan
            return base

        # Twice the points wanted, evenly along the curve, thinned evenly along the front;
        # DAS-CMOP3/6 fronts are short pieces of a wavy curve: ten times.
        t0 = even_along(lambda u: _base2(k, u), 0.0, 1.0, n_points * (10 if k % 3 == 0 else 2))
        F, t, s = lowest_feasible_curve(curve, t0, violation, span, shift, n_grid=600)
        sample = FrontSample(F, t[:, None], g_lo + s)
        nd = nondominated_index(F)
        sample = sample.take(nd[np.argsort(F[nd, 0], kind="stable")])
        return sample.take(thin_curve(sample.F, n_points))
    side = max(int(np.sqrt(n_points)), 2)
    x1, x2 = np.meshgrid(_type1_values(side, b), _type1_values(side, b, use_cos=True))
    pos = np.column_stack([x1.ravel(), x2.ravel()])
    F, index, s = lowest_feasible(_base3(k, pos[:, 0], pos[:, 1]) + g_lo, violation, span,
                                  shift=shift, n_grid=600)
    sample = FrontSample(F, pos[index], g_lo + s)
    return sample.take(nondominated_index(F))


def front(k: int, difficulty=8, n_points: int = 2000) -> np.ndarray:
    """Pareto front of DAS-CMOP``k`` (k = 1..9) at a difficulty (1..16 or a triplet)."""
    return front_sample(k, difficulty, n_points).F
