"""Shared data for the surrogate tests: smooth test functions on documented boxes.

Boxes (docs/surrogates.md, "Accuracy"): 10-D Rosenbrock on [0.5, 1.5]^10 and 10-D Ackley on
[-0.5, 0.5]^10, i.e. unit-wide neighbourhoods of each optimum (x* = 1 and x* = 0). On
the full standard domains neither model reaches R^2 = 0.9 with 300 points in 10-D (the
benchmark script prints those figures too).
"""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.problems.single import Ackley, Rosenbrock
from scipy.stats import qmc

BOXES = {"rosenbrock": (Rosenbrock(n_var=10), 0.5, 1.5),
         "ackley": (Ackley(n_var=10), -0.5, 0.5)}


def sample(name: str, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Latin-hypercube sample of ``n`` points of a 10-D box and the function values."""
    problem, lo, hi = BOXES[name]
    X = qmc.scale(qmc.LatinHypercube(d=10, seed=seed).random(n), lo, hi)
    return X, problem.evaluate(X)


def _r2(y: np.ndarray, pred: np.ndarray) -> np.ndarray:
    """Coefficient of determination per output column."""
    y, pred = y.reshape(len(y), -1), pred.reshape(len(pred), -1)
    return 1.0 - ((y - pred) ** 2).sum(0) / ((y - y.mean(0)) ** 2).sum(0)


@pytest.fixture(scope="session")
def r2():
    """R^2 per output: ``r2(y_true, y_pred) -> (m,)``."""
    return _r2


@pytest.fixture(scope="session")
def train_test():
    """300 training and 1000 held-out points per function (independent LHS designs)."""
    return {name: (sample(name, 300, 1), sample(name, 1000, 99)) for name in BOXES}


@pytest.fixture(scope="session")
def smooth3():
    """A small smooth 3-output problem in 4-D (fast tests of shapes and behaviour)."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 2, size=(40, 4))

    def f(X):
        return np.c_[np.sin(X).sum(1), (X ** 2).sum(1), X[:, 0] * X[:, 1] + 3.0]

    return X, f(X), f
