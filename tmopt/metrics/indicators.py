"""IGD, IGD+ and HV (pymoo's indicators), feasibility and the final non-dominated set."""

from __future__ import annotations

import numpy as np
from pymoo.indicators.hv import HV
from pymoo.indicators.igd import IGD
from pymoo.indicators.igd_plus import IGDPlus
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting


def _as_2d(name: str, A) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    if A.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array (points x objectives), got shape {A.shape}")
    return A


def igd(F, pareto_front) -> float:
    """Inverted generational distance of ``F`` to the true front (pymoo). NaN if F empty."""
    F, pf = _as_2d("F", F), _as_2d("pareto_front", pareto_front)
    return float(IGD(pf)(F)) if len(F) else float("nan")


def igd_plus(F, pareto_front) -> float:
    """IGD+ (Ishibuchi et al. 2015), pymoo's implementation. NaN if F empty."""
    F, pf = _as_2d("F", F), _as_2d("pareto_front", pareto_front)
    return float(IGDPlus(pf)(F)) if len(F) else float("nan")


def hypervolume(F, ref_point, ideal=None, nadir=None) -> float:
    """Hypervolume dominated by ``F`` up to ``ref_point`` (pymoo).

    With ``ideal`` and ``nadir`` given, objectives are first normalised to
    ``(F - ideal) / (nadir - ideal)`` and ``ref_point`` is read in that normalised space.
    Points that do not dominate the reference point contribute nothing; 0.0 if F is empty.
    """
    F = _as_2d("F", F)
    ref = np.asarray(ref_point, dtype=float)
    if ref.shape != (F.shape[1],):
        raise ValueError(f"ref_point must have {F.shape[1]} entries, got shape {ref.shape}")
    if ideal is not None and nadir is not None:
        scale = np.maximum(np.asarray(nadir, float) - np.asarray(ideal, float), 1e-12)
        F = (F - np.asarray(ideal, float)) / scale
    F = F[np.all(F < ref, axis=1)]
    return float(HV(ref_point=ref)(F)) if len(F) else 0.0


def feasible_ratio(G) -> float:
    """Share of designs with every constraint G <= 0 (1.0 for unconstrained problems)."""
    G = np.asarray(G, dtype=float)
    if G.ndim != 2:
        raise ValueError(f"G must be a 2-D array (designs x constraints), got shape {G.shape}")
    if len(G) == 0:
        return float("nan")
    return float(np.mean(np.all(G <= 0.0, axis=1)))


def constraint_violation(G) -> np.ndarray:
    """Total violation sum(max(G, 0)) per row."""
    G = np.asarray(G, dtype=float)
    if G.ndim != 2 or G.shape[1] == 0:
        return np.zeros(len(G))
    return np.sum(np.maximum(G, 0.0), axis=1)


def non_dominated_feasible(F, G, failed=None) -> np.ndarray:
    """Indices of the feasible, non-dominated, non-failed rows (unique in objective space).

    Empty when no design is feasible.
    """
    F, G = np.asarray(F, float), np.asarray(G, float)
    ok = np.ones(len(F), dtype=bool) if failed is None else ~np.asarray(failed, bool)
    ok &= np.all(np.isfinite(F), axis=1)
    if G.ndim == 2 and G.shape[1]:
        ok &= np.all(G <= 0.0, axis=1)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return idx
    front = NonDominatedSorting().do(F[idx], only_non_dominated_front=True)
    idx = idx[np.sort(front)]
    _, first = np.unique(F[idx], axis=0, return_index=True)
    return idx[np.sort(first)]
