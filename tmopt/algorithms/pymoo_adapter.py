"""Run any pymoo algorithm through tmopt's ask/tell interface and budget.

pymoo's own ask/tell loop is used unchanged: ``ask`` returns the offspring population,
the runner evaluates it (counted and archived), and the values are written back into the
population with pymoo's :class:`~pymoo.problems.static.StaticProblem` so that pymoo
computes constraint violation and feasibility exactly as it would itself.
:func:`as_tmopt_algorithm` wraps any pymoo algorithm object the same way, so
``run_optimisation(problem, pymoo_algorithm, budget=...)`` works; the other direction
(tmopt algorithms under pymoo's ``minimize``) is :mod:`tmopt.algorithms.as_pymoo`.
"""

from __future__ import annotations

import copy
from abc import abstractmethod

import numpy as np
from pymoo.core.algorithm import Algorithm as PymooAlgorithm
from pymoo.core.evaluator import Evaluator as PymooEvaluator
from pymoo.core.termination import NoTermination
from pymoo.problems.static import StaticProblem

from tmopt.algorithms.base import Algorithm
from tmopt.evaluation.evaluator import EvaluatedBatch


class PymooAdapter(Algorithm):
    """Base for wrappers around pymoo algorithms; subclasses build the pymoo object."""

    @abstractmethod
    def build(self) -> PymooAlgorithm:
        """Return a fresh pymoo algorithm for ``self.problem``."""

    def _setup(self) -> None:
        self._algorithm = self.build()
        self._algorithm.setup(self.problem, termination=NoTermination(), seed=self.seed,
                              verbose=False)
        self._pending = None

    def _infill(self) -> np.ndarray:
        self._pending = self._algorithm.ask()
        return self._pending.get("X")

    def _advance(self, batch: EvaluatedBatch) -> None:
        pop = self._pending[: len(batch.X)]
        values = {"F": batch.F}
        if self.problem.n_ieq_constr:
            values["G"] = batch.G
        PymooEvaluator().eval(StaticProblem(self.problem, **values), pop)
        self._algorithm.tell(infills=pop)
        self._pending = None

    def has_next(self) -> bool:
        return not self._algorithm.termination.has_terminated()


class WrappedPymooAlgorithm(PymooAdapter):
    """Any pymoo algorithm object, run by tmopt (budget, archive, resume, outputs).

    Args:
        algorithm: A pymoo algorithm, not yet set up; every run works on a copy of it.
    """

    def __init__(self, algorithm: PymooAlgorithm) -> None:
        self.name = type(algorithm).__name__.lower()
        super().__init__(pop_size=int(getattr(algorithm, "pop_size", None) or 2))
        self.template = algorithm

    def build(self) -> PymooAlgorithm:
        return copy.deepcopy(self.template)


def as_tmopt_algorithm(algorithm) -> Algorithm:
    """``algorithm`` itself if it is a tmopt algorithm, else a pymoo algorithm wrapped in
    :class:`WrappedPymooAlgorithm`; anything else is a one-line :class:`TypeError`."""
    if isinstance(algorithm, Algorithm):
        return algorithm
    if isinstance(algorithm, PymooAlgorithm):
        return WrappedPymooAlgorithm(algorithm)
    raise TypeError(f"algorithm must be a tmopt or pymoo algorithm, got "
                    f"{type(algorithm).__name__}")
