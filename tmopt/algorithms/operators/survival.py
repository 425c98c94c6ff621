"""Selection building blocks shared by MGSAEA(-IPC) and C-TSEA.

Everything here works on plain NumPy arrays (rows are solutions) so it serves real
evaluations and surrogate predictions alike. Minimisation throughout; ``cv`` is a total
constraint violation ``>= 0`` (0 = feasible).

* :func:`dominance_matrix` — Pareto dominance, or the constrained-dominance principle
  (CDP, Deb, CMAME 186, 2000): a smaller violation wins, equal violations (e.g. both
  feasible) compare by Pareto dominance. This is the relation of PlatEMO's two-argument
  ``CalFitness`` used by MGSAEA and C-TSEA.
* :func:`spea2_fitness` — SPEA2 fitness F(i) = R(i) + D(i) (Zitzler, Laumanns, Thiele,
  TIK-Report 103, 2001, Eqs. for S, R and D): S(i) counts whom i dominates, R(i) sums S
  over i's dominators, D(i) = 1 / (sigma_i^k + 2) with sigma_i^k the distance to the
  k-th nearest neighbour, k = floor(sqrt(N)). Non-dominated solutions have F < 1.
* :func:`environmental_selection` and :func:`truncation` — SPEA2's environmental
  selection: keep every F < 1 solution, fill up by fitness, or truncate by iteratively
  removing the solution whose sorted neighbour distances are lexicographically smallest.
* :func:`cdp_sort` — non-dominated sorting under CDP (feasible fronts first, then the
  infeasible solutions by increasing violation).
* :func:`change_rate` — the stage-switch function mc of the seed paper's Eq. 20.
* :func:`choose_granularity` — MGSAEA's surrogate granularity from the population's
  constraint satisfaction (Zhang et al., TNNLS 35(3), 2024, Sec. III; seed paper Sec. 3.2.2).
* :func:`tournament` — K-ary tournament on a fitness (lower is better), as PlatEMO's
  ``TournamentSelection``.
* :func:`ga_offspring` — PlatEMO's ``OperatorGA`` (SBX + polynomial mutation) on arrays,
  with pymoo's operator kernels.

Deviation from PlatEMO (documented in docs/algorithms-mgsaea.md): distances for the
density D(i) and for truncation are computed on objectives min-max normalised over the
set (``normalise=True``), because the paper's objectives differ by ~12 orders of
magnitude (seconds vs s^-2); ``normalise=False`` gives PlatEMO's raw distances.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pymoo.operators.crossover.sbx import cross_sbx
from pymoo.operators.mutation.pm import mut_pm
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
from scipy.spatial.distance import pdist, squareform

GRANULARITIES = ("coarse", "fine", "objectives")


def _as_matrix(name: str, F) -> np.ndarray:
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array (n, m), got shape {F.shape}")
    if not np.all(np.isfinite(F)):
        raise ValueError(f"{name} contains NaN or inf; drop or penalise failed designs first")
    return F


def _as_cv(cv, n: int) -> np.ndarray:
    cv = np.asarray(cv, dtype=float).reshape(-1)
    if cv.shape != (n,):
        raise ValueError(f"cv must have one value per solution ({n}), got shape {cv.shape}")
    if not np.all(np.isfinite(cv)):
        raise ValueError("cv contains NaN or inf")
    return np.maximum(cv, 0.0)


def total_violation(G: ArrayLike) -> np.ndarray:
    """Total constraint violation sum_j max(0, g_j) per row (0 where there are no columns)."""
    G = np.asarray(G, dtype=float)
    if G.ndim != 2 or G.shape[1] == 0:
        return np.zeros(len(G))
    return np.maximum(G, 0.0).sum(axis=1)


def normalised(F: np.ndarray) -> np.ndarray:
    """Columns min-max scaled to [0, 1] over the rows; constant columns become 0."""
    lo = F.min(axis=0)
    span = F.max(axis=0) - lo
    return (F - lo) / np.where(span > 0.0, span, 1.0)


def dominance_matrix(F: ArrayLike, cv: ArrayLike | None = None) -> np.ndarray:
    """``D[i, j]`` is True when solution i dominates j (constrained when ``cv`` is given).

    Pareto: i is no worse in every objective and better in at least one. CDP: i has the
    smaller violation, or the same violation and Pareto-dominates j.
    """
    F = _as_matrix("F", F)
    n = len(F)
    better = np.zeros((n, n), dtype=bool)
    worse = np.zeros((n, n), dtype=bool)
    for col in F.T:  # one (n, n) comparison per objective: no (n, n, m) temporaries
        better |= col[:, None] < col[None, :]
        worse |= col[:, None] > col[None, :]
    dom = better & ~worse
    if cv is not None:
        c = _as_cv(cv, len(F))
        dom = (c[:, None] < c[None, :]) | ((c[:, None] == c[None, :]) & dom)
    return dom


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
    F = _as_matrix("F", F)
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
    F = _as_matrix("F", F)
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
    F = _as_matrix("F", F)
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


def cdp_sort(F: ArrayLike, cv: ArrayLike) -> np.ndarray:
    """Front number (0 = best) of each solution under the constrained-dominance principle.

    Feasible solutions (``cv == 0``) are sorted into Pareto fronts (pymoo's fast
    non-dominated sorting); every infeasible solution comes after them, one front per
    distinct violation value in increasing order (CDP makes them a chain).
    """
    F = _as_matrix("F", F)
    c = _as_cv(cv, len(F))
    fronts = np.zeros(len(F), dtype=int)
    feas = np.flatnonzero(c == 0.0)
    n_front = 0
    if feas.size:
        ranks = NonDominatedSorting().do(F[feas], return_rank=True)[1]
        fronts[feas] = ranks
        n_front = int(ranks.max()) + 1
    infeas = np.flatnonzero(c > 0.0)
    if infeas.size:
        levels = np.unique(c[infeas], return_inverse=True)[1]
        fronts[infeas] = n_front + levels
    return fronts


def change_rate(ideal_now: ArrayLike, ideal_before: ArrayLike, sigma: float = 1e-3) -> float:
    """Maximum relative change mc of the ideal point (seed paper Eq. 20).

    mc = max_i |z_i^iter - z_i^(iter-gap)| / max(|z_i^(iter-gap)|, sigma). The absolute
    value in the denominator follows the paper; PlatEMO's ``calc_maxchange`` takes
    ``max(z, delta)`` without it, so a negative ideal component makes the denominator
    ``delta`` and mc explode (the stage never switches). See docs/algorithms-mgsaea.md.
    """
    now = np.asarray(ideal_now, dtype=float).reshape(-1)
    before = np.asarray(ideal_before, dtype=float).reshape(-1)
    if now.shape != before.shape or now.size == 0:
        raise ValueError(f"change_rate needs two ideal points of the same length, got "
                         f"{now.shape} and {before.shape}")
    if not sigma > 0.0:
        raise ValueError(f"change_rate: sigma must be > 0, got {sigma!r}")
    return float(np.max(np.abs(now - before) / np.maximum(np.abs(before), sigma)))


def choose_granularity(G: ArrayLike) -> tuple[str, np.ndarray]:
    """MGSAEA's surrogate granularity for a population with constraint values ``G``.

    A constraint is *not fully satisfied* when some member violates it (max_i g_ij > 0).

    Returns:
        ``("coarse", all)`` when every constraint is violated somewhere (far from the
        feasible region: objectives + one CV model, CDP); ``("fine", unsatisfied)`` when
        only some are (at the boundary: one model per unsatisfied constraint, violation
        as an extra objective); ``("objectives", [])`` when the whole population is
        feasible (or there are no constraints): objective models only.
    """
    G = np.asarray(G, dtype=float)
    if G.ndim != 2:
        raise ValueError(f"choose_granularity needs G of shape (n, n_constr), got {G.shape}")
    if G.shape[1] == 0 or len(G) == 0:
        return "objectives", np.zeros(0, dtype=int)
    unsatisfied = np.flatnonzero(np.max(G, axis=0) > 0.0)
    if unsatisfied.size == G.shape[1]:
        return "coarse", unsatisfied
    if unsatisfied.size:
        return "fine", unsatisfied
    return "objectives", unsatisfied


def tournament(fitness: ArrayLike, n: int, rng: np.random.Generator, k: int = 2) -> np.ndarray:
    """Indices of ``n`` winners of k-ary tournaments on ``fitness`` (lower is better).

    Ties go to the solution that comes first in a stable sort of the fitness, as in
    PlatEMO's ``TournamentSelection``.
    """
    fitness = np.asarray(fitness, dtype=float).reshape(-1)
    if len(fitness) == 0:
        raise ValueError("tournament needs at least one candidate")
    rank = np.empty(len(fitness), dtype=int)
    rank[np.argsort(fitness, kind="stable")] = np.arange(len(fitness))
    cand = rng.integers(0, len(fitness), size=(n, k))
    return cand[np.arange(n), np.argmin(rank[cand], axis=1)]


def unique_rows(A: ArrayLike, decimals: int | None = None) -> np.ndarray:
    """Indices of the first occurrence of each distinct row, in their original order."""
    A = np.asarray(A, dtype=float)
    key = A if decimals is None else np.round(A, decimals)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)


def ga_offspring(X: ArrayLike, mates: ArrayLike, xl: np.ndarray, xu: np.ndarray,
                 rng: np.random.Generator, crossover_eta: float = 20.0,
                 mutation_eta: float = 20.0) -> np.ndarray:
    """Two children per mating pair: SBX then polynomial mutation (PlatEMO's OperatorGA).

    SBX with probability 1 per pair, each variable crossed with probability 0.5 and the
    children swapped per variable with probability 0.5; polynomial mutation of each
    variable with probability 1/n_var. pymoo's array kernels (``cross_sbx``, ``mut_pm``)
    are called directly: its operator objects wrap every child in an ``Individual``,
    which cost more than the whole surrogate generation at 300 children.

    Args:
        X: Designs ``(n, n_var)``.
        mates: Pairs of row indices into ``X``, shape ``(n_pairs, 2)``.
        xl, xu: Bounds ``(n_var,)``.
    Returns:
        Children ``(2 * n_pairs, n_var)``: first children of all pairs, then second ones.
    """
    X = np.asarray(X, dtype=float)
    mates = np.asarray(mates, dtype=int)
    n_pairs, n_var = len(mates), X.shape[1]
    parents = np.stack([X[mates[:, 0]], X[mates[:, 1]]])
    half = np.full((n_pairs, 1), 0.5)
    Q = cross_sbx(parents, xl, xu, np.full((n_pairs, 1), float(crossover_eta)), half,
                  half.copy(), random_state=rng)
    off = Q.reshape(2 * n_pairs, n_var)
    return mut_pm(off, xl, xu, np.full(len(off), float(mutation_eta)),
                  np.full(len(off), min(0.5, 1.0 / n_var)), at_least_once=False,
                  random_state=rng)
