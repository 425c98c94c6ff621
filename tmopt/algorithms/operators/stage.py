"""The stage switch of MGSAEA and MGSAEA-IPC: when the search has stopped moving.

* :func:`change_rate` -- the maximum relative change mc of the ideal point over ``gap``
  iterations (seed paper Eq. 20); the algorithm moves to its next stage once mc falls
  to its threshold.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def change_rate(ideal_now: ArrayLike, ideal_before: ArrayLike, *, sigma: float,
                absolute: bool = True) -> float:
    """Maximum relative change mc of the ideal point (seed paper Eq. 20).

    mc = max_i |z_i^iter - z_i^(iter-gap)| / max(|z_i^(iter-gap)|, sigma). The absolute
    value in the denominator follows the paper; PlatEMO's ``calc_maxchange`` takes
    ``max(z, delta)`` without it, so a negative ideal component makes the denominator
    ``delta`` and mc explode (the stage never switches). See docs/algorithms-mgsaea.md.
    ``absolute=False`` reproduces PlatEMO's ``max(z, sigma)``.
    """
    now = np.asarray(ideal_now, dtype=float).reshape(-1)
    before = np.asarray(ideal_before, dtype=float).reshape(-1)
    if now.shape != before.shape or now.size == 0:
        raise ValueError(f"change_rate needs two ideal points of the same length, got "
                         f"{now.shape} and {before.shape}")
    if not sigma > 0.0:
        raise ValueError(f"change_rate: sigma must be > 0, got {sigma!r}")
    denom = np.maximum(np.abs(before) if absolute else before, sigma)
    return float(np.max(np.abs(now - before) / denom))
