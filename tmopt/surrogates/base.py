"""The surrogate interface shared by every model: ``fit(X, Y)``, ``predict(X) -> (mean, std)``.

Arrays are NumPy float64: ``X`` is ``(n, d)`` in the problem's own units, ``Y`` is
``(n, m)`` (one column per modelled output). ``predict`` returns ``mean`` and ``std`` of
shape ``(q, m)``; ``std`` is the model's predictive standard deviation of the latent
function (no observation noise), used by infill criteria. Models normalise inputs and
standardise outputs internally, so callers pass raw values.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np


class SurrogateError(RuntimeError):
    """A model could not be fitted even after its documented fallbacks."""


class Surrogate(ABC):
    """Base class of all surrogate models."""

    #: Short name used in configs and tables.
    name: str = "surrogate"

    @abstractmethod
    def fit(self, X: np.ndarray, Y: np.ndarray) -> Surrogate:
        """Fit to ``X (n, d)`` and ``Y (n, m)``; return ``self``."""

    @abstractmethod
    def predict(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predictive ``(mean, std)``, each ``(q, m)``, at ``X (q, d)``."""

    @staticmethod
    def check_training_data(X, Y) -> tuple[np.ndarray, np.ndarray]:
        """Validate and return float64 ``(n, d)`` and ``(n, m)`` arrays."""
        X = np.asarray(X, dtype=np.float64)
        Y = np.asarray(Y, dtype=np.float64)
        if Y.ndim == 1:
            Y = Y[:, None]
        if X.ndim != 2 or Y.ndim != 2 or len(X) != len(Y):
            raise ValueError(f"surrogate fit needs X (n, d) and Y (n, m) with the same n, "
                             f"got X {X.shape} and Y {Y.shape}")
        if len(X) < 2:
            raise ValueError(f"surrogate fit needs at least 2 points, got {len(X)}")
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
            raise ValueError("surrogate fit got NaN or inf in X or Y; drop failed designs first")
        return X, Y
