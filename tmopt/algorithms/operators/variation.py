"""Small parts shared by the baseline algorithms (C-MOEA/D, CMOES, SSDE, qLogNEHVI).

* :func:`nsga2_selection` -- NSGA-II's environmental selection under the constrained-
  dominance principle (CMOES stage one, SSDE).
* :func:`lexicographic_rank` -- turns (front, -crowding) into one tournament fitness.
* :func:`de_offspring` -- DE/rand/1/bin then polynomial mutation on pymoo's kernels
  (PlatEMO's ``OperatorDE``: CMOES with ``operator="de"``, SSDE).
* :func:`check_int`, :func:`check_number` -- constructor argument checks whose messages
  name the algorithm, the argument and the value.
"""

from __future__ import annotations

import numpy as np
from pymoo.operators.crossover.binx import mut_binomial
from pymoo.operators.crossover.dex import de_differential
from pymoo.operators.mutation.pm import mut_pm
from pymoo.operators.survival.rank_and_crowding.metrics import calc_crowding_distance

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.operators.survival import cdp_sort


def check_int(algorithm: str, label: str, value, minimum: int) -> int:
    """``value`` as an int, or :class:`AlgorithmConfigError` unless an integer >= minimum."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise AlgorithmConfigError(f"algorithm {algorithm}: {label} must be an integer "
                                   f">= {minimum}, got {value!r}")
    return int(value)


def check_number(algorithm: str, label: str, value, low: float, high: float = np.inf,
                 low_open: bool = False) -> float:
    """``value`` as a float, or :class:`AlgorithmConfigError` unless in [low, high].

    ``low_open`` makes the lower end exclusive, (low, high].
    """
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.floating)) \
        and np.isfinite(value) and (value > low if low_open else value >= low) \
        and value <= high
    if not ok:
        bracket = "(" if low_open else "["
        upper = "inf)" if high == np.inf else f"{high}]"
        raise AlgorithmConfigError(f"algorithm {algorithm}: {label} must be a finite number "
                                   f"in {bracket}{low}, {upper}, got {value!r}")
    return float(value)


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

    Whole fronts (:func:`~tmopt.algorithms.operators.survival.cdp_sort`) are kept while they fit;
    the last one is cut by crowding distance, largest first (ties: lower index).

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


def de_offspring(base: np.ndarray, r1: np.ndarray, r2: np.ndarray, problem,
                 rng: np.random.Generator, f: float = 0.5, cr: float = 1.0,
                 mutation_eta: float = 20.0) -> np.ndarray:
    """One child per row: DE/rand/1/bin, v = base + f (r1 - r2), then polynomial mutation.

    PlatEMO's ``OperatorDE`` (Storn & Price, J. Glob. Optim. 11, 1997): the donor is
    clipped to the bounds, each variable comes from the donor with probability ``cr``
    (no forced donor variable, as PlatEMO), then polynomial mutation with probability
    1/n_var per variable (Deb & Goyal 1996). pymoo's kernels ``de_differential`` and
    ``mut_binomial`` are used rather than its ``DEX`` operator, whose bound repair draws
    from an unseeded generator (pymoo 0.6.2), which would break reproducibility.
    """
    n = len(base)
    donor = de_differential(np.stack([base, r1, r2]), f, jitter=False, random_state=rng)
    donor = np.clip(donor, problem.xl, problem.xu)
    take = mut_binomial(n, base.shape[1], cr, at_least_once=False, random_state=rng)
    trial = np.where(take, donor, base)
    return mut_pm(trial, problem.xl, problem.xu, np.full(n, float(mutation_eta)),
                  np.full(n, min(0.5, 1.0 / problem.n_var)), at_least_once=False,
                  random_state=rng)
