"""The surrogate interface shared by every model: ``fit(X, Y)``, ``predict(X) -> (mean, std)``.

Arrays are NumPy float64: ``X`` is ``(n, d)`` in the problem's own units, ``Y`` is
``(n, m)`` (one column per modelled output). ``predict`` returns ``mean`` and ``std`` of
shape ``(q, m)``; ``std`` is the model's predictive standard deviation of the latent
function (no observation noise), used by infill criteria. Models normalise inputs and
standardise outputs internally, so callers pass raw values.

``predict_mean(X)`` returns the mean alone; models override it where the mean is much
cheaper than the standard deviation (the GP: O(q n) against O(q n^2) per output).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import torch


@contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run the block with ``n`` torch intra-op threads (0 = leave as is), then restore.

    Why: on a loaded 2-core machine, two OpenMP threads on these small matrices were
    measured 5-15x slower than one (docs/surrogates.md); the switch itself costs < 1 us.
    """
    if n <= 0 or n == torch.get_num_threads():
        yield
        return
    previous = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


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

    def predict_mean(self, X: np.ndarray) -> np.ndarray:
        """Predictive mean ``(q, m)`` at ``X (q, d)`` (same values as ``predict(X)[0]``)."""
        return self.predict(X)[0]

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
        if X.shape[1] < 1 or Y.shape[1] < 1:
            raise ValueError(f"surrogate fit needs d >= 1 and m >= 1, got X {X.shape} "
                             f"and Y {Y.shape}")
        if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
            raise ValueError("surrogate fit got NaN or inf in X or Y; drop failed designs first")
        return X, Y

    @staticmethod
    def check_query_data(X, d: int | None) -> np.ndarray:
        """Validate and return float64 query points ``(q, d)`` for a model fitted on ``d``.

        Raises :class:`SurrogateError` if the model is not fitted (``d is None``) and
        ``ValueError`` for a wrong shape or non-finite values.
        """
        if d is None:
            raise SurrogateError("predict called before fit")
        X = np.asarray(X, dtype=np.float64)
        if X.ndim == 1 and X.size == d:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != d:
            raise ValueError(f"predict needs X of shape (q, {d}), got {X.shape}")
        if not np.all(np.isfinite(X)):
            raise ValueError("predict got NaN or inf in X")
        return X
