"""Building blocks for offline Pareto fronts: lowest feasible point along a ray, ND filter.

Most constrained benchmarks share one structure: the attainable objective vectors are
``F(t, s)``, a *base* point ``B(t)`` of the unconstrained front (``t`` its position
variables) moved by a *distance* ``s >= s_min`` that grows with the distance function
``g`` of the problem (``s = g`` for MW and DTLZ, where ``F = g B(t)``; ``F = B(t) + g d``
for DAS-CMOP and MW1-3). ``F`` grows componentwise with ``s``, so for every ``t`` the
feasible point with the smallest ``s`` dominates all other feasible points of that ``t``
and the constrained front is the non-dominated subset of those lowest feasible points.
This is the construction PlatEMO uses in its ``GetOptimum`` methods (walk outwards in
steps of 0.1 % until feasible); here the walk runs on a grid and is then refined by
bisection, so the points lie on the constraint boundary to ~1e-12.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

Feasible = Callable[[np.ndarray], np.ndarray]


def _moved(base: np.ndarray, s: np.ndarray, shift: np.ndarray | None) -> np.ndarray:
    """``s * base`` (scale mode, ``shift`` None) or ``base + (s - s0) * shift`` rows."""
    s = np.asarray(s, dtype=float)[:, None]
    return base * s if shift is None else base + s * shift


@dataclass(frozen=True)
class FrontSample:
    """Front points with the variables that produce them.

    Attributes:
        F: (n, M) objective vectors.
        pos: (n, M-1) position parameters of each point (problem-specific meaning, e.g. the
            value of ``x_1`` or the point of the unconstrained front it was moved from).
        g: (n,) value of the problem's distance function at each point.
    """

    F: np.ndarray
    pos: np.ndarray
    g: np.ndarray

    def take(self, idx: np.ndarray) -> FrontSample:
        return FrontSample(self.F[idx], self.pos[idx], self.g[idx])


def lowest_feasible(base: np.ndarray, feasible: Feasible, s_max: float,
                    shift: np.ndarray | None = None, n_grid: int = 400,
                    n_bisect: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lowest feasible point on each ray ``F(s)``; rays with no feasible ``s`` are dropped.

    Args:
        base: (n, M) points at the smallest distance (``s = 1`` in scale mode, ``s = 0``
            in shift mode), which are checked exactly.
        feasible: (k, M) objective vectors -> (k,) bool, the constraints in objective space.
        s_max: Largest distance searched (scale factor, or shift length).
        shift: (M,) direction of the move in shift mode; None for scale mode.
        n_grid: Grid steps between the start and ``s_max`` (geometric in scale mode).
        n_bisect: Bisection steps refining the first feasible grid value.

    Returns:
        ``(F, index, s)``: the feasible points (k, M), the rows of ``base`` they come from
        and their distances. A feasible interval narrower than one grid step can be
        missed; problems with isolated feasible points add them to ``base`` explicitly.
    """
    base = np.asarray(base, dtype=float)
    s0 = 0.0 if shift is not None else 1.0
    grid = (np.linspace(0.0, s_max, n_grid + 1) if shift is not None
            else np.geomspace(1.0, s_max, n_grid + 1))
    n = len(base)
    ok = np.zeros((n, len(grid)), dtype=bool)
    for j, s in enumerate(grid):
        ok[:, j] = feasible(_moved(base, np.full(n, s), shift))
    index = np.flatnonzero(ok.any(axis=1))
    first = np.argmax(ok, axis=1)[index]
    base = base[index]
    hi = grid[first]
    lo = np.where(first > 0, grid[np.maximum(first - 1, 0)], s0)
    exact = first == 0
    for _ in range(n_bisect):
        mid = 0.5 * (lo + hi)
        good = feasible(_moved(base, mid, shift))
        hi = np.where(good & ~exact, mid, hi)
        lo = np.where(good | exact, lo, mid)
    return _moved(base, hi, shift), index, hi


def lowest_feasible_curve(curve: Callable[[np.ndarray], np.ndarray], t: np.ndarray,
                          feasible: Feasible, s_max: float, shift: np.ndarray | None = None,
                          levels: int = 4, per_gap: int = 16, n_grid: int = 400
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`lowest_feasible` along a curve ``B(t)``, refined where the result jumps.

    The lowest feasible distance can jump where one constraint takes over from another,
    and a front point just after such a jump is dominated by points just before it that
    a uniform grid may not contain. So every interval of ``t`` across which feasibility
    changes or the point moves by more than ten median steps gets ``per_gap`` extra
    samples, ``levels`` times over; the result then resolves each jump to about
    ``(t spacing) / per_gap**levels``.

    Returns:
        ``(F, t, s)`` of the feasible rays, ordered by ``t``.
    """
    t = np.unique(np.asarray(t, dtype=float))
    F, idx, s = lowest_feasible(curve(t), feasible, s_max, shift, n_grid)
    for _ in range(levels):
        extra = _gap_samples(t, idx, F, per_gap)
        if extra.size == 0:
            break
        F2, idx2, s2 = lowest_feasible(curve(extra), feasible, s_max, shift, n_grid)
        t_all = np.concatenate([t[idx], extra[idx2]])
        order = np.argsort(t_all)
        F = np.vstack([F, F2])[order]
        s = np.concatenate([s, s2])[order]
        t = np.union1d(t, extra)
        idx = np.searchsorted(t, t_all[order])
    return F, t[idx], s


def _gap_samples(t: np.ndarray, idx: np.ndarray, F: np.ndarray, per_gap: int) -> np.ndarray:
    """New t values inside the intervals where feasibility changes or F jumps."""
    found = np.zeros(len(t), dtype=bool)
    found[idx] = True
    point = np.full((len(t), F.shape[1]), np.nan)
    point[idx] = F
    step = np.linalg.norm(np.diff(point, axis=0), axis=1)
    typical = np.nanmedian(step) if np.any(np.isfinite(step)) else 0.0
    jump = (found[:-1] != found[1:]) | (np.nan_to_num(step, nan=0.0) > 10 * typical)
    lo, hi = t[:-1][jump], t[1:][jump]
    frac = np.arange(1, per_gap + 1) / (per_gap + 1)
    return (lo[:, None] + (hi - lo)[:, None] * frac[None, :]).ravel()


def thin_curve(F: np.ndarray, n_points: int) -> np.ndarray:
    """Indices of about ``n_points`` rows of a 2-D front spread evenly along it.

    ``F`` must be sorted by the first objective. Walking along it, a point is kept when it
    is at least ``h`` from the last kept one, with ``h`` the front's length (steps larger
    than ten median steps, i.e. gaps between pieces, not counted) over ``n_points``. The
    end points of every piece are always kept, so the front's extent is not shortened.
    """
    if len(F) <= n_points:
        return np.arange(len(F))
    step = np.linalg.norm(np.diff(F, axis=0), axis=1)
    gap = step > 10 * np.median(step)
    h = step[~gap].sum() / n_points
    keep = [0]
    walked = 0.0
    for i in range(1, len(F)):
        walked += step[i - 1]
        piece_end = i == len(F) - 1 or gap[i] or gap[i - 1]
        if walked >= h or piece_end:
            keep.append(i)
            walked = 0.0
    return np.array(keep)


def nondominated_index(F: np.ndarray) -> np.ndarray:
    """Rows of ``F`` that no other row dominates, one per distinct vector, sorted.

    Two objectives: a sort and a running minimum, O(n log n). More objectives: pymoo's
    non-dominated sorting.
    """
    F = np.asarray(F, dtype=float)
    if len(F) == 0:
        return np.zeros(0, dtype=int)
    _, first = np.unique(F, axis=0, return_index=True)
    first = np.sort(first)
    U = F[first]
    if F.shape[1] == 2:
        order = np.lexsort((U[:, 1], U[:, 0]))
        best_before = np.concatenate([[np.inf], np.minimum.accumulate(U[order][:-1, 1])])
        return np.sort(first[order[U[order][:, 1] < best_before]])
    front = NonDominatedSorting().do(U, only_non_dominated_front=True)
    return np.sort(first[front])


def nondominated(F: np.ndarray) -> np.ndarray:
    """The non-dominated rows of ``F`` (duplicates removed)."""
    F = np.asarray(F, dtype=float)
    return F[nondominated_index(F)]


def simplex_points(n_obj: int, n_points: int) -> np.ndarray:
    """About ``n_points`` evenly spread points of the unit simplex (Das & Dennis, pymoo)."""
    from pymoo.util.ref_dirs import get_reference_directions

    p = 1
    while _n_das_dennis(n_obj, p + 1) <= n_points:
        p += 1
    return get_reference_directions("das-dennis", n_obj, n_partitions=p)


def _n_das_dennis(n_obj: int, p: int) -> int:
    from math import comb

    return comb(p + n_obj - 1, n_obj - 1)


def sphere_points(n_obj: int, n_points: int) -> np.ndarray:
    """Simplex points projected onto the positive unit sphere."""
    W = simplex_points(n_obj, n_points)
    return W / np.linalg.norm(W, axis=1, keepdims=True)


def grid_front(base: np.ndarray, feasible: Feasible, s_values: np.ndarray,
               shift: np.ndarray | None = None) -> np.ndarray:
    """Brute-force front for checks: every base point at every distance, feasible, ND.

    Independent of :func:`lowest_feasible` (no walk, no bisection): all ``len(base) x
    len(s_values)`` candidates are evaluated and the non-dominated feasible ones kept.
    """
    base = np.asarray(base, dtype=float)
    s = np.repeat(np.asarray(s_values, dtype=float), len(base))
    F = _moved(np.tile(base, (len(s_values), 1)), s, shift)
    return nondominated(F[feasible(F)])
