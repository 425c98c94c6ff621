"""Constraint handling: the constrained-dominance principle and MGSAEA's granularity.

Everything here works on plain NumPy arrays (rows are solutions), so it serves real
evaluations and surrogate predictions alike. Minimisation throughout; ``cv`` is a total
constraint violation ``>= 0`` (0 = feasible), as
:func:`tmopt.metrics.indicators.constraint_violation` computes it.

* :func:`dominance_matrix` -- Pareto dominance, or the constrained-dominance principle
  (CDP, Deb, CMAME 186, 2000): a smaller violation wins, equal violations (e.g. both
  feasible) compare by Pareto dominance. This is the relation of PlatEMO's two-argument
  ``CalFitness`` used by MGSAEA and C-TSEA.
* :func:`cdp_sort` -- non-dominated sorting under CDP (feasible fronts first, then the
  infeasible solutions by increasing violation).
* :func:`choose_granularity` -- MGSAEA's surrogate granularity from the population's
  constraint satisfaction (Zhang et al., TNNLS 35(3), 2024, Sec. III; seed paper Sec. 3.2.2).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting


def as_objectives(name: str, F) -> np.ndarray:
    """``F`` as a finite 2-D float array (n, m), or ValueError naming it."""
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


def dominance_matrix(F: ArrayLike, cv: ArrayLike | None = None) -> np.ndarray:
    """``D[i, j]`` is True when solution i dominates j (constrained when ``cv`` is given).

    Pareto: i is no worse in every objective and better in at least one. CDP: i has the
    smaller violation, or the same violation and Pareto-dominates j.
    """
    F = as_objectives("F", F)
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


def cdp_sort(F: ArrayLike, cv: ArrayLike) -> np.ndarray:
    """Front number (0 = best) of each solution under the constrained-dominance principle.

    Feasible solutions (``cv == 0``) are sorted into Pareto fronts (pymoo's fast
    non-dominated sorting); every infeasible solution comes after them, one front per
    distinct violation value in increasing order (CDP makes them a chain).
    """
    F = as_objectives("F", F)
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
