"""Offline Pareto fronts of the constrained DTLZ problems (Jain & Deb, IEEE TEVC 18(4),
2014, Sec. VI-A), for any number of objectives M.

DTLZ1 reaches ``F = 0.5 (1 + g) w`` (w on the unit simplex) and DTLZ2-4 reach
``F = (1 + g) u`` (u on the positive unit sphere), g >= 0. The constraints (pymoo's
``cdtlz.py``) depend on F only, so the fronts follow in objective space:

* C1-DTLZ1: the DTLZ1 simplex ``sum f = 1/2`` is feasible, so it is the front.
* C1-DTLZ3: the unit sphere (radius 1 < 4, inside the feasible core) is the front.
* C2-DTLZ2: the unit sphere restricted to the feasible caps; along the infeasible
  directions no larger radius becomes feasible (checked by the generic construction of
  :func:`generic_front` in the tests).
* C3-DTLZ1: the lowest feasible point along every direction lies on the constraint
  boundary: ``c_j = 1 - 2 f_j - sum_{i != j} f_i <= 0`` with ``F = s w`` gives
  ``s (1 + w_j) >= 1`` for all j, hence ``F = w / (1 + min_j w_j)``.
* C3-DTLZ4: likewise ``c_j = 1 - f_j^2 / 4 - sum_{i != j} f_i^2 <= 0`` with ``F = s u``
  gives ``F = u / sqrt(1 - 3/4 max_j u_j^2)`` (as Jain & Deb, Eq. for C3 problems).
"""

from __future__ import annotations

import numpy as np

from tmopt.problems.fronts.sampling import (
    lowest_feasible,
    nondominated,
    simplex_points,
    sphere_points,
)


def c2_radius(n_obj: int) -> float:
    """C2-DTLZ2's r: 0.4 for M = 3, 0.5 otherwise (Jain & Deb 2014; 0.2 for M = 2, pymoo)."""
    return 0.2 if n_obj == 2 else (0.4 if n_obj == 3 else 0.5)


def c1dtlz3_radius(n_obj: int) -> float:
    """C1-DTLZ3's outer radius r: 9 (M < 5), 12.5 (5 <= M <= 12), 15 (more)."""
    return 9.0 if n_obj < 5 else (12.5 if n_obj <= 12 else 15.0)


def constraints(name: str, F: np.ndarray) -> np.ndarray:
    """G (n, n_constr), G <= 0 feasible, of a C-DTLZ problem at objective vectors F."""
    F = np.atleast_2d(np.asarray(F, dtype=float))
    M = F.shape[1]
    if name == "c1dtlz1":
        return (F[:, -1] / 0.6 + (F[:, :-1] / 0.5).sum(1) - 1)[:, None]
    if name == "c1dtlz3":
        r2 = (F ** 2).sum(1)
        return (-(r2 - 16) * (r2 - c1dtlz3_radius(M) ** 2))[:, None]
    if name == "c2dtlz2":
        r = c2_radius(M)
        sq = (F ** 2).sum(1, keepdims=True)
        near_axis = ((F - 1) ** 2 + sq - F ** 2 - r ** 2).min(1)
        near_centre = ((F - 1 / np.sqrt(M)) ** 2).sum(1) - r ** 2
        return np.minimum(near_axis, near_centre)[:, None]
    if name == "c3dtlz1":
        return 1 - F / 0.5 - (F.sum(1, keepdims=True) - F)
    if name == "c3dtlz4":
        sq = F ** 2
        return 1 - sq / 4 - (sq.sum(1, keepdims=True) - sq)
    raise ValueError(f"unknown C-DTLZ problem {name!r}; choose one of: c1dtlz1, c1dtlz3, "
                     "c2dtlz2, c3dtlz1, c3dtlz4")


def generic_front(name: str, n_obj: int, n_points: int) -> np.ndarray:
    """Front by the generic construction: lowest feasible point along each direction."""
    base = 0.5 * simplex_points(n_obj, n_points) if name.endswith("dtlz1") \
        else sphere_points(n_obj, n_points)
    violation = lambda F: constraints(name, F).max(axis=1)  # noqa: E731
    return nondominated(lowest_feasible(base, violation, s_max=4.0, n_grid=800)[0])


def front(name: str, n_obj: int = 3, n_points: int = 2000) -> np.ndarray:
    """Pareto front of a C-DTLZ problem with ``n_obj`` objectives (about n_points rows)."""
    if name == "c1dtlz1":
        return 0.5 * simplex_points(n_obj, n_points)
    if name == "c1dtlz3":
        return sphere_points(n_obj, n_points)
    if name == "c2dtlz2":
        U = sphere_points(n_obj, n_points)
        return U[constraints(name, U)[:, 0] <= 0.0]
    if name == "c3dtlz1":
        W = simplex_points(n_obj, n_points)
        return nondominated(W / (1 + W.min(1, keepdims=True)))
    if name == "c3dtlz4":
        U = sphere_points(n_obj, n_points)
        return U / np.sqrt(1 - 0.75 * (U ** 2).max(1, keepdims=True))
    return constraints(name, np.zeros((1, n_obj)))  # raises the ValueError naming the choices
