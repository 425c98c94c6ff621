"""LIR-CMOP1-14: constrained multi-objective problems with large infeasible regions.

Fan, Li, Cai, Huang, Fang, You, Mo, Wei and Goodman, "An improved epsilon
constraint-handling method in MOEA/D for CMOPs with large infeasible regions", Soft
Computing 23 (2019) 12491-12510 (Sec. 5, the test problems). pymoo does not have them;
the definitions below follow the paper, cross-checked against PlatEMO's MATLAB
(``Problems/Multi-objective optimization/LIR-CMOP``) and jMetal's Java, which differ from
it and from each other in places (docs/benchmark-problems.md, "LIR-CMOP"):

* LIR-CMOP1-4 (paper): ``f1 = x1 + g1``, ``f2 = 1 - h(x1) + g2`` with ``h = x1^2`` (1, 3)
  or ``sqrt(x1)`` (2, 4), ``g1 = sum_{j in J1} (x_j - sin(pi x1 / 2))^2``,
  ``g2 = sum_{j in J2} (x_j - cos(pi x1 / 2))^2``, J1 = {3, 5, ...}, J2 = {2, 4, ...}
  (1-based); constraints ``(a - g_i)(g_i - b) >= 0``, a = 0.51, b = 0.5; LIR-CMOP3-4 add
  ``sin(20 pi x1) - 0.5 >= 0``. (PlatEMO's LIR-CMOP2-4 use ``x1`` in place of
  ``sin/cos(pi x1 / 2)`` in g; the fronts are the same.)
* LIR-CMOP5-8: ``f1 = x1 + 10 g1 + 0.7057``, ``f2 = 1 - h(x1) + 10 g2 + 0.7057`` with
  ``g1 = sum_{j odd >= 3} (x_j - sin(0.5 j / n pi x1))^2``, ``g2`` over even j with cos;
  ``h = sqrt`` (5, 7) or the square (6, 8); constraints: outside two (5, 6) or three
  (7, 8) rotated ellipses in objective space.
* LIR-CMOP9-12: ``f1 = 1.7057 x1 (10 g1 + 1)``, ``f2 = 1.7057 (1 - h(x1)) (10 g2 + 1)``,
  ``h`` the square (9, 12) or sqrt (10, 11); constraints: outside one ellipse and above a
  wavy line ``f1 sin a + f2 cos a - sin(4 pi (f1 cos a - f2 sin a)) >= c``, a = pi/4.
* LIR-CMOP13-14 (three objectives): ``F = (1.7057 + g) * (unit sphere point of x1, x2)``
  with ``g = sum_{j >= 3} 10 (x_j - 0.5)^2``; constraints are rings on ``|F|^2``: two
  (13) or three (14) bands ``(|F|^2 - lo^2)(|F|^2 - hi^2) >= 0``.

Here every constraint is written ``G <= 0`` feasible (pymoo's convention), i.e. the
paper's ``c(x) >= 0`` is negated; the values equal PlatEMO's ``PopCon``.
"""

from __future__ import annotations

import numpy as np
from pymoo.core.problem import Problem

#: Number of objectives and constraints of each problem.
N_OBJ = {k: (3 if k >= 13 else 2) for k in range(1, 15)}
N_CONSTR = {1: 2, 2: 2, 3: 3, 4: 3, 5: 2, 6: 2, 7: 3, 8: 3, 9: 2, 10: 2, 11: 2, 12: 2,
            13: 2, 14: 3}
#: The distance-free offset of LIR-CMOP5-8 and the radius of LIR-CMOP9-14's curves.
OFFSET = 0.7057
RADIUS = 1.7057
#: Smallest number of variables: LIR-CMOP1-4 need two variables in each of J1 and J2 for
#: g_i = 0.5 to be reachable for every x1 (one variable reaches it only for centres
#: below 0.29 or above 0.71), so their front is the published one only from n = 5 on; LIR-CMOP13-14
#: need the suites' n_obj + 1.
MIN_N_VAR = {k: (5 if k <= 12 else 4) for k in range(1, 15)}

# Ellipses (p, q, a, b) of LIR-CMOP5-12, r = 0.1, rotated by theta = -pi/4 (the paper's
# Table; PlatEMO's Constraint functions hold the same numbers).
_ELLIPSES = {
    5: ((1.6, 1.6, 2.0, 4.0), (2.5, 2.5, 2.0, 8.0)),
    6: ((1.8, 1.8, 2.0, 8.0), (2.8, 2.8, 2.0, 8.0)),
    7: ((1.2, 1.2, 2.0, 6.0), (2.25, 2.25, 2.5, 12.0), (3.5, 3.5, 2.5, 10.0)),
    8: ((1.2, 1.2, 2.0, 6.0), (2.25, 2.25, 2.5, 12.0), (3.5, 3.5, 2.5, 10.0)),
    9: ((1.4, 1.4, 1.5, 6.0),),
    10: ((1.1, 1.2, 2.0, 4.0),),
    11: ((1.2, 1.2, 1.5, 5.0),),
    12: ((1.6, 1.6, 1.5, 6.0),),
}
ELLIPSE_R = 0.1
THETA = -0.25 * np.pi
#: Level c of the wavy-line constraint of LIR-CMOP9-12, with alpha = pi/4, N = 4.
_WAVE = {9: 2.0, 10: 1.0, 11: 2.1, 12: 2.5}
ALPHA = 0.25 * np.pi
#: Squared radii bounding the infeasible rings of LIR-CMOP13-14 (lo^2, hi^2).
_RINGS = {13: ((4.0, 9.0), (3.24, 3.61)), 14: ((4.0, 9.0), (3.24, 3.61), (2.56, 3.0625))}


def concave(k: int) -> bool:
    """True where ``h(x1) = x1^2`` (a concave front), False where ``h = sqrt(x1)``."""
    return k in (1, 3, 6, 8, 9, 12)


def h(k: int, t: np.ndarray) -> np.ndarray:
    """The shape function of the 2-objective problems' unconstrained front."""
    return t ** 2 if concave(k) else np.sqrt(t)


def ellipse_constraints(k: int, F: np.ndarray) -> np.ndarray:
    """``r - u^2/a^2 - v^2/b^2`` per ellipse of LIR-CMOP``k`` (``<= 0``: outside)."""
    c, s = np.cos(THETA), np.sin(THETA)
    cols = []
    for p, q, a, b in _ELLIPSES[k]:
        u = (F[:, 0] - p) * c - (F[:, 1] - q) * s
        v = (F[:, 0] - p) * s + (F[:, 1] - q) * c
        cols.append(ELLIPSE_R - u ** 2 / a ** 2 - v ** 2 / b ** 2)
    return np.column_stack(cols)


def wave_constraint(k: int, F: np.ndarray) -> np.ndarray:
    """``c - f1 sin a - f2 cos a + sin(4 pi (f1 cos a - f2 sin a))`` (``<= 0`` feasible)."""
    w = F[:, 0] * np.cos(ALPHA) - F[:, 1] * np.sin(ALPHA)
    return _WAVE[k] - F[:, 0] * np.sin(ALPHA) - F[:, 1] * np.cos(ALPHA) + np.sin(4 * np.pi * w)


def objective_constraints(k: int, F: np.ndarray) -> np.ndarray:
    """The constraints of LIR-CMOP5-14, which depend on the objectives only, (n, n_constr)."""
    F = np.asarray(F, dtype=float)
    if 5 <= k <= 8:
        return ellipse_constraints(k, F)
    if 9 <= k <= 12:
        return np.column_stack([ellipse_constraints(k, F), wave_constraint(k, F)])
    if k in _RINGS:
        r2 = (F ** 2).sum(axis=1)
        return np.column_stack([(r2 - hi) * (lo - r2) for lo, hi in _RINGS[k]])
    raise ValueError(f"LIR-CMOP{k} has constraints on the variables, not only the objectives")


def centres(k: int, x1: np.ndarray, n_var: int) -> tuple[np.ndarray, np.ndarray]:
    """Values of x_j (odd j >= 3; even j >= 2; 1-based) that make g1 and g2 zero, (n, |J|)."""
    x1 = np.asarray(x1, dtype=float)[:, None]
    odd, even = np.arange(3, n_var + 1, 2)[None, :], np.arange(2, n_var + 1, 2)[None, :]
    if k <= 4:  # the paper's form (PlatEMO's LIR-CMOP1 and jMetal)
        return (np.sin(0.5 * np.pi * x1) * np.ones(odd.shape),
                np.cos(0.5 * np.pi * x1) * np.ones(even.shape))
    return np.sin(0.5 * odd / n_var * np.pi * x1), np.cos(0.5 * even / n_var * np.pi * x1)


class LIRCMOP(Problem):
    """LIR-CMOP``k`` (k = 1..14), vectorised over a population, ``x`` in [0, 1]^n.

    Args:
        k: Problem number, 1..14.
        n_var: Number of variables (published: 30); at least 5 (4 for LIR-CMOP13-14).
    """

    def __init__(self, k: int, n_var: int = 30) -> None:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= 14:
            raise ValueError(f"LIR-CMOP problem number must be an integer in 1..14, got {k!r}")
        if isinstance(n_var, bool) or not isinstance(n_var, (int, np.integer)) \
                or n_var < MIN_N_VAR[k]:
            raise ValueError(f"problem lircmop{k}: n_var must be an integer >= "
                             f"{MIN_N_VAR[k]}, got {n_var!r}")
        self.k = int(k)
        super().__init__(n_var=int(n_var), n_obj=N_OBJ[k], n_ieq_constr=N_CONSTR[k],
                         xl=0.0, xu=1.0, vtype=float)

    def _evaluate(self, X, out, *args, **kwargs):
        X = np.asarray(X, dtype=float)
        k = self.k
        if k >= 13:
            g = 10 * ((X[:, 2:] - 0.5) ** 2).sum(axis=1)
            a, b = 0.5 * np.pi * X[:, 0], 0.5 * np.pi * X[:, 1]
            F = (RADIUS + g)[:, None] * np.column_stack(
                [np.cos(a) * np.cos(b), np.cos(a) * np.sin(b), np.sin(a)])
            out["F"], out["G"] = F, objective_constraints(k, F)
            return
        x1 = X[:, 0]
        c_odd, c_even = centres(k, x1, self.n_var)
        g1 = ((X[:, 2::2] - c_odd) ** 2).sum(axis=1)
        g2 = ((X[:, 1::2] - c_even) ** 2).sum(axis=1)
        if k <= 4:
            F = np.column_stack([x1 + g1, 1 - h(k, x1) + g2])
            G = [(0.5 - g1) * (0.51 - g1), (0.5 - g2) * (0.51 - g2)]
            if k >= 3:
                G.append(0.5 - np.sin(20 * np.pi * x1))
            out["F"], out["G"] = F, np.column_stack(G)
            return
        if k <= 8:
            F = np.column_stack([x1 + 10 * g1 + OFFSET, 1 - h(k, x1) + 10 * g2 + OFFSET])
        else:
            F = RADIUS * np.column_stack([x1 * (10 * g1 + 1), (1 - h(k, x1)) * (10 * g2 + 1)])
        out["F"], out["G"] = F, objective_constraints(k, F)
