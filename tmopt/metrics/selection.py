"""Choosing one solution from a Pareto set (paper Eq. 21)."""

from __future__ import annotations

import numpy as np


def best_compromise(F) -> int:
    """Index of the point nearest the normalised ideal point (paper Eq. 21).

    Eq. 21: x_best = argmin_x sqrt(sum_i ((obj_i - obj_i^min) / obj_i^min)^2), i.e. every
    objective is divided by its minimum over the set and the distance to the unit point
    is minimised. The paper's objectives (convergence time, RMSE) are positive. Where an
    objective's minimum is <= 0 (benchmarks), dividing by it is meaningless, so that
    objective is normalised by its range instead (docs/decisions.md, "Eq. 21").
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2 or len(F) == 0:
        raise ValueError(f"best_compromise needs a non-empty 2-D array, got shape {F.shape}")
    fmin = F.min(axis=0)
    span = F.max(axis=0) - fmin
    scale = np.where(fmin > 0.0, fmin, np.where(span > 0.0, span, 1.0))
    dist = np.sqrt(np.sum(((F - fmin) / scale) ** 2, axis=1))
    return int(np.argmin(dist))
