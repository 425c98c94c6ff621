"""Survival: who stays in a population (SPEA2 and NSGA-II environmental selection).

Everything here works on plain NumPy arrays (rows are solutions) so it serves real
evaluations and surrogate predictions alike. Minimisation throughout; ``cv`` is a total
constraint violation ``>= 0`` (0 = feasible); the dominance relation is
:func:`~tmopt.algorithms.operators.constraints.dominance_matrix`.

* :func:`spea2_fitness` -- SPEA2 fitness F(i) = R(i) + D(i) (Zitzler, Laumanns, Thiele,
  TIK-Report 103, 2001, Eqs. for S, R and D): S(i) counts whom i dominates, R(i) sums S
  over i's dominators, D(i) = 1 / (sigma_i^k + 2) with sigma_i^k the distance to the
  k-th nearest neighbour, k = floor(sqrt(N)). Non-dominated solutions have F < 1.
* :func:`environmental_selection` and :func:`truncation` -- SPEA2's environmental
  selection: keep every F < 1 solution, fill up by fitness, or truncate by iteratively
  removing the solution whose sorted neighbour distances are lexicographically smallest.
* :func:`nsga2_selection` -- NSGA-II's environmental selection under the constrained-
  dominance principle (CMOES stage one, SSDE), with :func:`crowding_per_front`.
* :func:`lexicographic_rank` -- turns (front, -crowding) into one tournament fitness.
* :func:`farthest_points` -- greedy max-min-distance growth of a chosen set (KTA2's DA
  in KTS, PEA's last-front selection).

Deviation from PlatEMO (documented in docs/algorithms-mgsaea.md): distances for the
density D(i) and for truncation are computed on objectives min-max normalised over the
set (``normalise=True``), because the paper's objectives differ by ~12 orders of
magnitude (seconds vs s^-2); ``normalise=False`` gives PlatEMO's raw distances.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pymoo.operators.survival.rank_and_crowding.metrics import calc_crowding_distance
from scipy.spatial.distance import pdist, squareform

from tmopt.algorithms.operators.constraints import as_objectives, cdp_sort, dominance_matrix


def normalised(F: np.ndarray) -> np.ndarray:
    """Columns min-max scaled to [0, 1] over the rows; constant columns become 0."""
    lo = F.min(axis=0)
    span = F.max(axis=0) - lo
    return (F - lo) / np.where(span > 0.0, span, 1.0)


def _kth_neighbour_distance(F: np.ndarray, k: int) -> np.ndarray:
    dist = squareform(pdist(F)) if len(F) > 1 else np.zeros((len(F), len(F)))
    np.fill_diagonal(dist, np.inf)
    k = min(k, max(len(F) - 1, 1))
    return np.partition(dist, k - 1, axis=1)[:, k - 1]


def spea2_fitness(F: ArrayLike, cv: ArrayLike | None = None, *,
                  normalise: bool = True) -> np.ndarray:
    """SPEA2 fitness R(i) + D(i) (lower is better; non-dominated solutions have < 1).

    Args:
        F: Objectives ``(n, m)``; the density uses distances between these rows.
        cv: Optional total violation ``(n,)``; dominance is then CDP.
        normalise: Measure density on min-max normalised objectives (see module doc).
    """
    F = as_objectives("F", F)
    n = len(F)
    if n == 0:
        return np.zeros(0)
    dom = dominance_matrix(F, cv)
    strength = dom.sum(axis=1).astype(float)            # S(i)
    raw = dom.T.astype(float) @ strength                 # R(i) = sum of S over dominators
    k = int(np.floor(np.sqrt(n)))
    sigma = _kth_neighbour_distance(normalised(F) if normalise else F, k)
    return raw + 1.0 / (sigma + 2.0)


def truncation(F: ArrayLike, n_remove: int, *, normalise: bool = True) -> np.ndarray:
    """Boolean mask of the ``n_remove`` solutions SPEA2's truncation deletes.

    Each step deletes the solution whose distances to the remaining ones, sorted
    ascending, are lexicographically smallest (ties: lowest index, as MATLAB's
    ``sortrows``). Only rows attaining the current minimum nearest-neighbour distance
    can win, so each step sorts just those rows, and nearest neighbours are updated only
    for the rows that lost theirs: O(n^2) in all instead of a full sort per step.
    """
    F = as_objectives("F", F)
    n = len(F)
    if not 0 <= n_remove <= n:
        raise ValueError(f"truncation: n_remove={n_remove} must be in [0, {n}]")
    deleted = np.zeros(n, dtype=bool)
    if n_remove == 0:
        return deleted
    X = normalised(F) if normalise else F
    dist = squareform(pdist(X)) if n > 1 else np.zeros((1, 1))
    np.fill_diagonal(dist, np.inf)
    nn_idx = np.argmin(dist, axis=1)
    nn = dist[np.arange(n), nn_idx]
    for _ in range(n_remove):
        cand = np.flatnonzero((nn == nn[~deleted].min()) & ~deleted)
        rows = np.sort(dist[cand], axis=1)  # deleted columns are inf in every row alike
        # np.lexsort sorts by the last key first, so pass columns reversed; stable.
        gone = cand[np.lexsort(rows.T[::-1])[0]]
        deleted[gone] = True
        dist[gone, :] = np.inf
        dist[:, gone] = np.inf
        nn[gone] = np.inf
        lost = np.flatnonzero(~deleted & (nn_idx == gone))
        if lost.size:
            nn_idx[lost] = np.argmin(dist[lost], axis=1)
            nn[lost] = dist[lost, nn_idx[lost]]
    return deleted


def environmental_selection(fitness: ArrayLike, F: ArrayLike, n: int, *,
                            normalise: bool = True) -> np.ndarray:
    """Indices (ascending) of the ``n`` survivors of SPEA2's environmental selection.

    Args:
        fitness: SPEA2 fitness of every solution (from :func:`spea2_fitness`).
        F: Objectives used by the truncation (rows aligned with ``fitness``).
        n: Number of survivors; all are kept when there are at most ``n``.
    """
    fitness = np.asarray(fitness, dtype=float).reshape(-1)
    F = as_objectives("F", F)
    if len(F) != len(fitness):
        raise ValueError(f"fitness has {len(fitness)} rows but F has {len(F)}")
    if n >= len(fitness):
        return np.arange(len(fitness))
    if n < 0:
        raise ValueError(f"environmental_selection: n={n} must be >= 0")
    keep = fitness < 1.0
    if keep.sum() < n:
        keep[:] = False
        keep[np.argsort(fitness, kind="stable")[:n]] = True
    elif keep.sum() > n:
        idx = np.flatnonzero(keep)
        keep[idx[truncation(F[idx], len(idx) - n, normalise=normalise)]] = False
    return np.flatnonzero(keep)


def farthest_points(D: np.ndarray, chosen: np.ndarray, n_total: int) -> np.ndarray:
    """Grow the boolean mask ``chosen`` to ``n_total`` by adding, one at a time, the row
    whose smallest distance ``D`` to the chosen rows is largest (ties: lowest index)."""
    chosen = chosen.copy()
    while chosen.sum() < min(n_total, len(D)):
        rest = np.flatnonzero(~chosen)
        gap = D[np.ix_(rest, np.flatnonzero(chosen))].min(axis=1)
        chosen[rest[np.argmax(gap)]] = True
    return chosen


def crowding_per_front(F: np.ndarray, front: np.ndarray) -> np.ndarray:
    """Crowding distance (pymoo's) of each row within its own front."""
    crowd = np.zeros(len(F))
    for f in np.unique(front):
        members = np.flatnonzero(front == f)
        crowd[members] = calc_crowding_distance(F[members])
    return crowd


def nsga2_selection(F: np.ndarray, cv: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray,
                                                                     np.ndarray]:
    """NSGA-II environmental selection under CDP (Deb et al., IEEE TEVC 6(2), 2002).

    Whole fronts (:func:`~tmopt.algorithms.operators.constraints.cdp_sort`) are kept while
    they fit; the last one is cut by crowding distance, largest first (ties: lower index).

    Returns:
        Indices (ascending) of the ``n`` survivors, their fronts and crowding distances.
    """
    front = cdp_sort(F, cv)
    crowd = crowding_per_front(F, front)
    if n >= len(F):
        keep = np.arange(len(F))
    else:
        last = np.sort(front)[n - 1]
        kept = np.flatnonzero(front < last)
        tied = np.flatnonzero(front == last)
        order = np.argsort(-crowd[tied], kind="stable")
        keep = np.sort(np.concatenate([kept, tied[order[: n - len(kept)]]]))
    return keep, front[keep], crowd[keep]


def lexicographic_rank(*keys: np.ndarray) -> np.ndarray:
    """Position of each row sorted by ``keys[0]``, then ``keys[1]``, ... (stable).

    PlatEMO's ``TournamentSelection`` with several fitness columns ranks by ``sortrows``;
    this rank is the equivalent single fitness (lower is better).
    """
    order = np.lexsort(tuple(reversed(keys)))
    rank = np.empty(len(order), dtype=float)
    rank[order] = np.arange(len(order))
    return rank
