"""NSGA-II (Deb et al., IEEE TEVC 6(2), 2002) — pymoo's implementation.

Tags: multi-objective, constrained (constrained-dominance), not surrogate-assisted.

Parameters (keyword arguments; defaults: the constructor's signature):
    pop_size: population size; every generation evaluates ``pop_size`` offspring.
    crossover_eta, crossover_prob: simulated binary crossover.
    mutation_eta: polynomial mutation (probability 1/n_var per variable).
"""

from __future__ import annotations

from pymoo.algorithms.moo.nsga2 import NSGA2 as _NSGA2
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM

from tmopt.algorithms.base import check_number
from tmopt.algorithms.pymoo_adapter import PymooAdapter


class NSGA2(PymooAdapter):
    name = "nsga2"

    def __init__(self, *, pop_size: int = 100, crossover_eta: float = 15.0,
                 crossover_prob: float = 0.9, mutation_eta: float = 20.0) -> None:
        super().__init__(pop_size=pop_size)
        prob = check_number(self.name, "crossover_prob", crossover_prob, 0.0, 1.0)
        eta = check_number(self.name, "crossover_eta", crossover_eta, 0.0)
        self.crossover = SBX(prob=prob, eta=eta)
        self.mutation = PM(eta=check_number(self.name, "mutation_eta", mutation_eta, 0.0))

    def build(self) -> _NSGA2:
        return _NSGA2(pop_size=self.pop_size, crossover=self.crossover, mutation=self.mutation,
                      eliminate_duplicates=True)
