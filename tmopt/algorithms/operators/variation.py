"""Variation: choosing parents and making children from them.

* :func:`tournament` -- K-ary tournament on a fitness (lower is better), as PlatEMO's
  ``TournamentSelection``.
* :func:`ga_offspring` -- PlatEMO's ``OperatorGA`` (SBX + polynomial mutation) on arrays,
  with pymoo's operator kernels (MGSAEA, C-TSEA, CMOES, KTS); ``mutation=False`` gives
  SBX alone and :func:`polynomial_mutation` mutation alone (KTA2's two offspring streams
  in KTS, ``OperatorGA`` with ``{1,20,0,0}`` and ``{0,0,1,20}``).
* :func:`de_offspring` -- DE/rand/1/bin then polynomial mutation on pymoo's kernels
  (PlatEMO's ``OperatorDE``: CMOES with ``operator="de"``, SSDE).
* :func:`unique_rows` -- drops repeated children before they are evaluated.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pymoo.operators.crossover.binx import mut_binomial
from pymoo.operators.crossover.dex import de_differential
from pymoo.operators.crossover.sbx import cross_sbx
from pymoo.operators.mutation.pm import mut_pm
from scipy.spatial.distance import cdist

#: Designs closer than this (per variable, relative to the bounds) count as the same design.
SAME_DESIGN_TOL = 1e-9


def already_evaluated(X: np.ndarray, seen: np.ndarray, xl: np.ndarray,
                      xu: np.ndarray) -> np.ndarray:
    """(n,) bool: rows of ``X`` (n, D) within SAME_DESIGN_TOL (Chebyshev, relative to the
    bounds) of a row of ``seen`` (m, D) -- a design the algorithm must not pay for twice."""
    if len(X) == 0 or len(seen) == 0:
        return np.zeros(len(X), dtype=bool)
    span = xu - xl
    return (cdist(X / span, seen / span, metric="chebyshev") <= SAME_DESIGN_TOL).any(axis=1)


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
                 rng: np.random.Generator, *, crossover_eta: float,
                 mutation_eta: float, mutation: bool = True) -> np.ndarray:
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
        crossover_eta, mutation_eta: SBX and polynomial-mutation distribution indices
            (the calling algorithm's settings).
        mutation: False returns the SBX children unmutated.
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
    return polynomial_mutation(off, xl, xu, rng, mutation_eta=mutation_eta) if mutation \
        else off


def polynomial_mutation(X: ArrayLike, xl: np.ndarray, xu: np.ndarray,
                        rng: np.random.Generator, *, mutation_eta: float) -> np.ndarray:
    """Polynomial mutation (Deb & Goyal 1996) of every row, each variable with
    probability 1/n_var, pymoo's ``mut_pm`` kernel (PlatEMO's ``OperatorGA`` mutation)."""
    X = np.asarray(X, dtype=float)
    return mut_pm(X, xl, xu, np.full(len(X), float(mutation_eta)),
                  np.full(len(X), min(0.5, 1.0 / X.shape[1])), at_least_once=False,
                  random_state=rng)


def de_offspring(base: np.ndarray, r1: np.ndarray, r2: np.ndarray, problem,
                 rng: np.random.Generator, *, f: float = 0.5, cr: float = 1.0,
                 mutation_eta: float) -> np.ndarray:
    """One child per row: DE/rand/1/bin, v = base + f (r1 - r2), then polynomial mutation.

    PlatEMO's ``OperatorDE`` (Storn & Price, J. Glob. Optim. 11, 1997): the donor is
    clipped to the bounds, each variable comes from the donor with probability ``cr``
    (no forced donor variable, as PlatEMO), then polynomial mutation with probability
    1/n_var per variable (Deb & Goyal 1996). pymoo's kernels ``de_differential`` and
    ``mut_binomial`` are used rather than its ``DEX`` operator, whose bound repair draws
    from an unseeded generator (pymoo 0.6.2), which would break reproducibility. ``f`` and
    ``cr`` default to ``OperatorDE``'s own values, which CMOES uses as PlatEMO does; SSDE
    passes its settings.
    """
    n = len(base)
    donor = de_differential(np.stack([base, r1, r2]), f, jitter=False, random_state=rng)
    donor = np.clip(donor, problem.xl, problem.xu)
    take = mut_binomial(n, base.shape[1], cr, at_least_once=False, random_state=rng)
    trial = np.where(take, donor, base)
    return mut_pm(trial, problem.xl, problem.xu, np.full(n, float(mutation_eta)),
                  np.full(n, min(0.5, 1.0 / problem.n_var)), at_least_once=False,
                  random_state=rng)
