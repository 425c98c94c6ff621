"""NSGA-III (Deb & Jain, IEEE TEVC 18(4), 2014) — pymoo's implementation.

Tags: multi-/many-objective, constrained (constrained-dominance), not surrogate-assisted.

Parameters (keyword arguments; defaults: the constructor's signature):
    pop_size: population size; reference directions are Das-Dennis with the largest
        number of partitions whose point count does not exceed ``pop_size``.
    crossover_eta, crossover_prob, mutation_eta: SBX and polynomial
        mutation as in the NSGA-III paper.
"""

from __future__ import annotations

from math import comb

from pymoo.algorithms.moo.nsga3 import NSGA3 as _NSGA3
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from pymoo.util.ref_dirs import get_reference_directions

from tmopt.algorithms.base import check_number
from tmopt.algorithms.pymoo_adapter import PymooAdapter


class NSGA3(PymooAdapter):
    name = "nsga3"

    def __init__(self, *, pop_size: int = 100, crossover_eta: float = 30.0,
                 crossover_prob: float = 1.0, mutation_eta: float = 20.0) -> None:
        super().__init__(pop_size=pop_size)
        prob = check_number(self.name, "crossover_prob", crossover_prob, 0.0, 1.0)
        eta = check_number(self.name, "crossover_eta", crossover_eta, 0.0)
        self.crossover = SBX(prob=prob, eta=eta)
        self.mutation = PM(eta=check_number(self.name, "mutation_eta", mutation_eta, 0.0))

    def build(self) -> _NSGA3:
        n_obj = self.problem.n_obj
        ref_dirs = get_reference_directions("das-dennis", n_obj,
                                            n_partitions=partitions_for(n_obj, self.pop_size))
        return _NSGA3(ref_dirs=ref_dirs, pop_size=self.pop_size, crossover=self.crossover,
                      mutation=self.mutation, eliminate_duplicates=True)


def partitions_for(n_obj: int, max_points: int) -> int:
    """Largest Das-Dennis partition count with at most ``max_points`` directions."""
    p = 1
    while comb(p + 1 + n_obj - 1, n_obj - 1) <= max_points:
        p += 1
    return p
