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

Violation = Callable[[np.ndarray], np.ndarray]


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


def lowest_feasible(base: np.ndarray, violation: Violation, s_max: float,
                    shift: np.ndarray | None = None, n_grid: int = 400, n_bisect: int = 40,
                    n_dips: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lowest feasible point on each ray ``F(s)``; rays with no feasible ``s`` are dropped.

    The rays are scanned on a grid of ``s``. A feasible interval can be thinner than a
    grid step (e.g. a band between two nearby constraint curves); the violation then dips
    between grid points without reaching 0. So up to ``n_dips`` local minima of the
    violation before the first feasible grid point are searched by golden section, and
    the lowest feasible ``s`` found either way is refined by bisection.

    Args:
        base: (n, M) points at the smallest distance (``s = 1`` in scale mode, ``s = 0``
            in shift mode), which are checked exactly.
        violation: (k, M) objective vectors -> (k,) largest constraint value (``<= 0``
            feasible, NaN infeasible), the constraints in objective space.
        s_max: Largest distance searched (scale factor, or shift length).
        shift: (M,) direction of the move in shift mode; None for scale mode.
        n_grid: Grid steps between the start and ``s_max`` (geometric in scale mode).
        n_bisect: Bisection steps refining the first feasible value.
        n_dips: Local minima of the violation searched per ray.

    Returns:
        ``(F, index, s)``: the feasible points (k, M), the rows of ``base`` they come from
        and their distances. Isolated feasible points (width 0) can still be missed;
        problems that have them add them to ``base`` explicitly.
    """
    base = np.asarray(base, dtype=float)
    s0 = 0.0 if shift is not None else 1.0
    grid = (np.linspace(0.0, s_max, n_grid + 1) if shift is not None
            else np.geomspace(1.0, s_max, n_grid + 1))
    n = len(base)
    V = np.empty((n, len(grid)))
    for j, s in enumerate(grid):
        V[:, j] = _violation(violation, _moved(base, np.full(n, s), shift))
    ok = V <= 0.0
    first = np.where(ok.any(axis=1), np.argmax(ok, axis=1), len(grid))
    lo = np.where(first > 0, grid[np.maximum(first - 1, 0)], s0)
    hi = np.where(first < len(grid), grid[np.minimum(first, len(grid) - 1)], np.nan)
    lo, hi = _search_dips(base, violation, shift, grid, V, first, lo, hi, n_dips)
    index = np.flatnonzero(np.isfinite(hi))
    base, lo, hi = base[index], lo[index], hi[index]
    exact = hi == s0
    for _ in range(n_bisect):
        mid = 0.5 * (lo + hi)
        good = _violation(violation, _moved(base, mid, shift)) <= 0.0
        hi = np.where(good & ~exact, mid, hi)
        lo = np.where(good | exact, lo, mid)
    return _moved(base, hi, shift), index, hi


def _violation(violation: Violation, F: np.ndarray) -> np.ndarray:
    v = np.asarray(violation(F), dtype=float)
    return np.where(np.isnan(v), np.inf, v)


def _search_dips(base, violation, shift, grid, V, first, lo, hi, n_dips):
    """Golden-section search of the violation's dips before each ray's first feasible s."""
    inner = V[:, 1:-1]
    cols = np.arange(1, len(grid) - 1)[None, :]
    # a smooth violation sampled at three points can sink below the middle value by about
    # the dip's depth, so only dips not much higher than deep can hide a feasible band
    with np.errstate(invalid="ignore"):
        depth = np.maximum(V[:, :-2], V[:, 2:]) - inner
        dip = ((inner <= V[:, :-2]) & (inner <= V[:, 2:]) & (inner > 0) & (inner < 2 * depth)
               & (cols < first[:, None]))
    rank = np.cumsum(dip, axis=1) * dip
    lo, hi = lo.copy(), hi.copy()
    for r in range(1, n_dips + 1):
        rows = np.flatnonzero((rank == r).any(axis=1))
        if rows.size == 0:
            break
        j = np.argmax(rank[rows] == r, axis=1) + 1
        a, b = grid[j - 1], grid[j + 1]
        rays = base[rows]
        s_min, v_min = _golden_min(
            lambda s, rays=rays: _violation(violation, _moved(rays, s, shift)), a, b)
        better = (v_min <= 0.0) & ~(hi[rows] <= a)  # feasible, and below what was found
        lo[rows[better]], hi[rows[better]] = a[better], s_min[better]
    return lo, hi


def _golden_min(f, a: np.ndarray, b: np.ndarray, n_iter: int = 50):
    """Vectorised golden-section minimisation of ``f`` on [a, b]; returns (s, f(s))."""
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = a.astype(float).copy(), b.astype(float).copy()
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(n_iter):
        left = fc <= fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        c_new, d_new = b - ratio * (b - a), a + ratio * (b - a)
        f_new = f(np.where(left, c_new, d_new))
        fc, fd = np.where(left, f_new, fd), np.where(left, fc, f_new)
        c, d = np.where(left, c_new, d), np.where(left, c, d_new)
    s = np.where(fc <= fd, c, d)
    return s, np.minimum(fc, fd)


def even_along(curve: Callable[[np.ndarray], np.ndarray], lo: float, hi: float,
               n: int) -> np.ndarray:
    """``n`` values of ``t`` in [lo, hi] spacing the points ``curve(t)`` evenly by arc length.

    Uniform ``t`` leaves steep parts of a front (e.g. a circle near an axis) sparsely
    sampled; IGD then weighs them less. Rows of ``curve`` that are NaN count as length 0.
    """
    fine = np.linspace(lo, hi, 20 * n + 1)
    pts = curve(fine)
    step = np.nan_to_num(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    arc = np.concatenate([[0.0], np.cumsum(step)])
    if arc[-1] == 0.0:
        return np.linspace(lo, hi, n)
    return np.interp(np.linspace(0.0, arc[-1], n), arc, fine)


def lowest_feasible_curve(curve: Callable[[np.ndarray], np.ndarray], t: np.ndarray,
                          violation: Violation, s_max: float, shift: np.ndarray | None = None,
                          levels: int = 4, per_gap: int = 16, n_grid: int = 400
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`lowest_feasible` along a 2-D curve ``B(t)``, refined where the front changes.

    Pieces of a constrained front end where feasibility changes, where the lowest
    feasible distance jumps (one constraint takes over from another), where the points
    leave the unconstrained curve, or where the curve turns back and its points become
    dominated. A uniform grid resolves such an end only to its spacing, and a point just
    past it can look non-dominated among the samples while the true end point dominates
    it. So every interval of ``t`` across which one of these changes gets ``per_gap``
    extra samples (and so do the intervals next to it), ``levels`` times over: piece ends
    are resolved to about
    ``(t spacing) / per_gap**levels``.

    Returns:
        ``(F, t, s)`` of the feasible rays, ordered by ``t``.
    """
    t = np.unique(np.asarray(t, dtype=float))
    s0 = 0.0 if shift is not None else 1.0
    F, idx, s = lowest_feasible(curve(t), violation, s_max, shift, n_grid)
    # a jump is a step ten times the typical step of the initial samples (held fixed, as
    # refined samples are closer together)
    steps = np.linalg.norm(np.diff(F, axis=0), axis=1)
    jump = 10 * np.median(steps) if steps.size else np.inf
    for _ in range(levels):
        extra = _gap_samples(t, idx, F, s == s0, per_gap, jump)
        if extra.size == 0:
            break
        F2, idx2, s2 = lowest_feasible(curve(extra), violation, s_max, shift, n_grid)
        t_all = np.concatenate([t[idx], extra[idx2]])
        order = np.argsort(t_all)
        F = np.vstack([F, F2])[order]
        s = np.concatenate([s, s2])[order]
        t = np.union1d(t, extra)
        idx = np.searchsorted(t, t_all[order])
    return F, t[idx], s


def _gap_samples(t: np.ndarray, idx: np.ndarray, F: np.ndarray, on_curve: np.ndarray,
                 per_gap: int, jump: float) -> np.ndarray:
    """New t values inside the intervals where one of the properties above changes."""
    n = len(t)
    found = np.zeros(n, dtype=bool)
    found[idx] = True
    state = np.full((n, 2), -1)  # (on the unconstrained curve, non-dominated) per t
    nd = np.zeros(len(F), dtype=bool)
    nd[nondominated_index(F)] = True
    state[idx, 0], state[idx, 1] = on_curve, nd
    point = np.full((n, F.shape[1]), np.nan)
    point[idx] = F
    step = np.linalg.norm(np.diff(point, axis=0), axis=1)
    change = (found[:-1] != found[1:]) | np.any(state[:-1] != state[1:], axis=1)
    change |= np.nan_to_num(step, nan=0.0) > jump
    # also the neighbouring intervals: a piece can end (e.g. at a minimum of f2) one
    # sample before the first sample whose status differs
    change = change | np.roll(change, 1) | np.roll(change, -1)
    lo, hi = t[:-1][change], t[1:][change]
    frac = np.arange(1, per_gap + 1) / (per_gap + 1)
    return (lo[:, None] + (hi - lo)[:, None] * frac[None, :]).ravel()


def thin_curve(F: np.ndarray, n_points: int) -> np.ndarray:
    """Indices of about ``n_points`` rows of a 2-D front spread evenly along it.

    ``F`` must be sorted by the first objective. Walking along it, a point is kept when it
    is at least ``h`` from the last kept one, with ``h`` the front's length over
    ``n_points``; steps longer than ``5 h`` count as gaps between pieces, are left out of
    the length, and the end points of every piece are always kept, so no piece is
    shortened.
    """
    if len(F) <= 2:
        return np.arange(len(F))
    step = np.linalg.norm(np.diff(F, axis=0), axis=1)
    gap = step > 5 * step.sum() / n_points
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


def grid_front(base: np.ndarray, violation: Violation, s_values: np.ndarray,
               shift: np.ndarray | None = None) -> np.ndarray:
    """Brute-force front for checks: every base point at every distance, feasible, ND.

    Independent of :func:`lowest_feasible` (no walk, no bisection): all ``len(base) x
    len(s_values)`` candidates are evaluated and the non-dominated feasible ones kept.
    """
    base = np.asarray(base, dtype=float)
    s = np.repeat(np.asarray(s_values, dtype=float), len(base))
    F = _moved(np.tile(base, (len(s_values), 1)), s, shift)
    return nondominated(F[_violation(violation, F) <= 0.0])
