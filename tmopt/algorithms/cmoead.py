"""C-MOEA/D: MOEA/D-PBI with a constrained replacement rule.

Tags: constrained, multi-/many-objective, decomposition, not surrogate-assisted (every
offspring is evaluated for real; a Table 3 baseline of the seed paper).

Implements
    H. Jain and K. Deb, "An evolutionary many-objective optimization algorithm using
    reference-point based non-dominated sorting approach, part II: handling constraints
    and extending to an adaptive approach", IEEE TEVC 18(4): 602-622, 2014 (C-MOEA/D),
    on MOEA/D (Zhang & Li, IEEE TEVC 11(6): 712-731, 2007) with the neighbourhood
    mating and bounded replacement of MOEA/D-DE (Li & Zhang, IEEE TEVC 13(2): 284-302,
    2009). Reference code: PlatEMO's ``CMOEAD.m``; pymoo's ``MOEAD`` is the base class.
    The paper's full text was not available here: the parameters and the rule below are
    those of the issue and of CMOEAD.m (docs/algorithms-baselines.md lists what is
    unverified).

Parameters (keyword arguments; defaults: the constructor's signature):
    pop_size: upper bound of the population; the population is the number N of
        Das-Dennis weight vectors, the most partitions with at most ``pop_size`` points
        (N = pop_size for two objectives). The initial sample is N random designs.
    n_neighbors: neighbourhood size T; None = ceil(N / 10) (PlatEMO), at least 2
        (two parents are drawn from it).
    max_replacements: most solutions one child may replace, nr; None =
        ceil(N / 100) (PlatEMO).
    prob_neighbor_mating: probability delta that parents (and the replacement pool)
        come from the neighbourhood instead of the whole population.
    theta: PBI penalty (Zhang & Li 2007, Eq. for g^pbi), the value of Jain & Deb.
    crossover_eta, crossover_prob, mutation_eta: SBX and polynomial
        mutation (1/n_var per variable); one child per mating (PlatEMO's OperatorGAhalf).
    batch_size: children proposed per ask. 1 is MOEA/D's steady state (each child is
        evaluated and used before the next is bred); a larger value breeds that many
        children from the same population, evaluates them as one batch (useful when the
        problem evaluates a batch in parallel), then applies them one by one.

Algorithm (one step per child; subproblems visited in order i = 1..N, as CMOEAD.m):

1. With probability ``prob_neighbor_mating`` the pool P is subproblem i's T nearest
   weight vectors (Euclidean, itself included), else the whole population; P is shuffled
   and its first two members are the parents of one SBX + PM child.
2. The ideal point z is updated with the child's objectives, feasible or not (CMOEAD.m).
3. Constrained replacement (Jain & Deb 2014, as CMOEAD.m): for each j in P (shuffled order),
   the child replaces x_j when CV(child) < CV(x_j), or when the violations are equal
   (e.g. both feasible) and g^pbi(child | w_j, z) <= g^pbi(x_j | w_j, z), where
   CV = sum_k max(0, g_k) and g^pbi = d1 + theta * d2 (pymoo's ``PBI``). At most
   ``max_replacements`` members are replaced.

Documented in docs/algorithms-baselines.md, with what could not be checked against the
paper text.
"""

from __future__ import annotations

from math import ceil, comb

import numpy as np
from pymoo.algorithms.moo.moead import MOEAD
from pymoo.core.population import Population
from pymoo.decomposition.pbi import PBI
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from pymoo.util.ref_dirs import get_reference_directions
from scipy.spatial.distance import cdist

from tmopt.algorithms.base import AlgorithmConfigError, check_int, check_number
from tmopt.algorithms.nsga3 import partitions_for
from tmopt.algorithms.pymoo_adapter import PymooAdapter
from tmopt.problems.base import ExpensiveProblem


class ConstrainedMOEAD(MOEAD):
    """pymoo's MOEA/D with Jain & Deb's constrained replacement (a pymoo algorithm).

    Args:
        ref_dirs: Weight vectors ``(N, M)``.
        n_neighbors: Neighbourhood size T.
        max_replacements: At most this many replacements per child (nr).
        theta: PBI penalty.
        batch_size: Children per ``ask`` (1 = steady state).
        prob_neighbor_mating: Probability of mating (and replacing) within the neighbourhood.
        kwargs: Passed to :class:`pymoo.algorithms.moo.moead.MOEAD` (crossover, mutation).
    The values come from :class:`CMOEAD`, whose signature holds the defaults.
    """

    def __init__(self, ref_dirs: np.ndarray, n_neighbors: int, max_replacements: int,
                 *, theta: float, batch_size: int, prob_neighbor_mating: float,
                 **kwargs) -> None:
        super().__init__(ref_dirs=ref_dirs, n_neighbors=n_neighbors,
                         decomposition=PBI(theta=theta),
                         prob_neighbor_mating=prob_neighbor_mating, **kwargs)
        self.prob_neighbor_mating = float(prob_neighbor_mating)
        self.max_replacements = max_replacements
        self.batch_size = batch_size
        self._next_subproblem = 0
        self._pools: list[np.ndarray] = []

    def _setup(self, problem, **kwargs) -> None:
        # pymoo's MOEAD._setup refuses constrained problems; this class handles them.
        self.pop_size = len(self.ref_dirs)
        dist = cdist(self.ref_dirs, self.ref_dirs)
        # Stable sort: ties between equally distant weights keep index order (as MATLAB).
        self.neighbors = np.argsort(dist, axis=1, kind="stable")[:, : self.n_neighbors]

    def _infill(self) -> Population:
        children, self._pools = [], []
        for _ in range(self.batch_size):
            pool = self._mating_pool(self._next_subproblem)
            self._next_subproblem = (self._next_subproblem + 1) % self.pop_size
            children.append(self._breed(pool[:2]))
            self._pools.append(pool)
        return Population.create(*[ind for child in children for ind in child])

    def _mating_pool(self, i: int) -> np.ndarray:
        """Shuffled neighbourhood of subproblem i (probability delta) or whole population."""
        rnd = self.random_state
        if rnd.random() < self.prob_neighbor_mating:
            return rnd.permutation(self.neighbors[i])
        return rnd.permutation(self.pop_size)

    def _breed(self, parents: np.ndarray) -> Population:
        """One child of SBX + PM on two parents (SBX exchanges variables between its two
        children with probability 0.5 each, so keeping the first is a random half)."""
        return self.mating.do(self.problem, self.pop, 1, parents=self.pop[parents[None, :]],
                              n_max_iterations=1, random_state=self.random_state)

    def _advance(self, infills: Population | None = None, **kwargs) -> None:
        # Ideal point from every child of the batch, feasible or not (CMOEAD.m).
        self.ideal = np.min(np.vstack([self.ideal, infills.get("F")]), axis=0)
        for child, pool in zip(infills, self._pools, strict=False):
            self._replace_constrained(pool, child)

    def _replace_constrained(self, pool: np.ndarray, child) -> None:
        """Jain & Deb's rule: smaller violation wins, equal violation -> PBI (ties replace)."""
        members = self.pop[pool]
        cv_old, cv_new = members.get("CV")[:, 0], float(child.CV[0])
        weights = self.ref_dirs[pool]
        g_old = self.decomposition.do(members.get("F"), weights=weights,
                                      ideal_point=self.ideal)
        g_new = self.decomposition.do(np.repeat(child.F[None, :], len(pool), axis=0),
                                      weights=weights, ideal_point=self.ideal)
        better = (cv_new < cv_old) | ((cv_new == cv_old) & (g_new <= g_old))
        for j in pool[np.flatnonzero(better)[: self.max_replacements]]:
            self.pop[j] = child


class CMOEAD(PymooAdapter):
    """C-MOEA/D (see the module docstring for parameters and the algorithm)."""

    name = "cmoead"

    def __init__(self, *, pop_size: int = 100, n_neighbors: int | None = None,
                 max_replacements: int | None = None, prob_neighbor_mating: float = 0.9,
                 theta: float = 5.0, crossover_eta: float = 20.0, crossover_prob: float = 1.0,
                 mutation_eta: float = 20.0, batch_size: int = 1) -> None:
        super().__init__(pop_size=pop_size)
        name = self.name
        self.n_neighbors = _optional(check_int, name, "n_neighbors", n_neighbors, 2)
        self.max_replacements = _optional(check_int, name, "max_replacements",
                                          max_replacements, 1)
        self.prob_neighbor_mating = check_number(name, "prob_neighbor_mating",
                                                 prob_neighbor_mating, 0.0, 1.0)
        self.theta = check_number(name, "theta", theta, 0.0)
        self.crossover_eta = check_number(name, "crossover_eta", crossover_eta, 0.0)
        self.crossover_prob = check_number(name, "crossover_prob", crossover_prob, 0.0, 1.0)
        self.mutation_eta = check_number(name, "mutation_eta", mutation_eta, 0.0)
        self.batch_size = check_int(name, "batch_size", batch_size, 1)

    # ---- framework hooks ----------------------------------------------------------------
    def n_weights(self, problem: ExpensiveProblem) -> int:
        """Population size N = number of Das-Dennis weight vectors (<= pop_size)."""
        m = int(problem.n_obj)
        if m < 2:
            raise AlgorithmConfigError(f"algorithm {self.name}: needs at least 2 objectives, "
                                       f"problem {problem.name} has {m}")
        h = partitions_for(m, self.pop_size)
        return comb(h + m - 1, m - 1)

    def initial_sample_size(self, problem: ExpensiveProblem) -> int:
        return self.n_weights(problem)

    def info(self) -> dict:
        return {"N": self._algorithm.pop_size, "T": self._algorithm.n_neighbors}

    def build(self) -> ConstrainedMOEAD:
        m = self.problem.n_obj
        ref_dirs = get_reference_directions("das-dennis", m,
                                            n_partitions=partitions_for(m, self.pop_size))
        n = len(ref_dirs)
        T = self.n_neighbors if self.n_neighbors is not None else ceil(n / 10)
        if T > n:
            raise AlgorithmConfigError(f"algorithm {self.name}: n_neighbors={T} exceeds the "
                                       f"population of {n} weight vectors")
        nr = self.max_replacements if self.max_replacements is not None else ceil(n / 100)
        return ConstrainedMOEAD(
            ref_dirs, n_neighbors=max(T, 2), max_replacements=nr, theta=self.theta,
            batch_size=self.batch_size, prob_neighbor_mating=self.prob_neighbor_mating,
            crossover=SBX(prob=self.crossover_prob, eta=self.crossover_eta),
            mutation=PM(prob=1.0, eta=self.mutation_eta))


def _optional(check, algorithm: str, label: str, value, minimum: int) -> int | None:
    """None (use the default rule) or a checked value."""
    return None if value is None else check(algorithm, label, value, minimum)
