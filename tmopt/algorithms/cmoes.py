"""CMOES: constrained multi-objective optimisation by even search in a promising region.

Tags: constrained, multi-objective, three populations, not surrogate-assisted (every
offspring is evaluated for real; a Table 3 baseline of the seed paper).

Implements
    F. Ming, W. Gong, Y. Jin, "Even search in a promising region for constrained
    multi-objective optimization", IEEE/CAA Journal of Automatica Sinica 11(2): 474-486,
    2024. Reference code: PlatEMO ``Algorithms/Multi-objective optimization/CMOES``
    (``CMOES.m``, ``EvenSearch.m``, ``GetLable.m``, ``CalFitness.m``, written by the first
    author), which this module follows; the paper's full text was not available here.

Parameters (keyword arguments; defaults: the constructor's signature):
    pop_size: size N of the main population P1; the helper populations P2 and P3
        hold at most N each. The initial sample is 2N random designs (P1 and P2).
    operator: variation, PlatEMO's ``type``: "ga" = SBX + polynomial mutation,
        "de" = DE/rand/1/bin (F = 0.5, CR = 1) + polynomial mutation.
    stage_ratio: share of the generations (counted as PlatEMO does, ceil(FE / N)
        out of ceil(budget / N)) spent in stage one at least.
    crossover_eta, mutation_eta: SBX and polynomial mutation (1/n_var per
        variable) distribution indices, PlatEMO's defaults.
    normalise: SPEA2 density and truncation distances on min-max normalised
        objectives (False = PlatEMO's raw distances), as everywhere in tmopt because the
        seed problem's objectives differ by ~12 orders of magnitude.

Algorithm (CMOES.m; CV = sum_k max(0, g_k)):

Stage one, while P1 holds no feasible design or gen <= stage_ratio * maxgen:
    * P1 evolves with NSGA-II under the constrained-dominance principle (binary tournament
      on front then crowding distance; GA keeps both SBX children: 2N offspring, DE: N);
    * P2 evolves with SPEA2 on the objectives only (constraints ignored; binary tournament
      on its fitness, one child per pair: N offspring);
    * both populations select from themselves + all offspring; P3 is a copy of P2.
Stage two (the even search):
    * the promising region is the part of objective space not Pareto-dominated by any
      feasible member of P1 (GetLable.m);
    * P1 keeps N of [P1, P2, P3, offspring] by SPEA2 environmental selection under
      constrained dominance (a smaller CV always dominates, CalFitness.m);
    * P2 keeps the members of the promising region that are non-dominated there (SPEA2
      fitness < 1 on the objectives), truncated to N: they accelerate convergence;
    * P3 keeps the members of the promising region with CV <= eps = max_cv (1 - tau)^2,
      tau = gen / maxgen, truncated to N: they explore the (relaxed) feasible regions;
    * each population breeds its own offspring (|P1| + |P2| + |P3| <= 3N evaluations), P2
      by a tournament on its SPEA2 fitness and P3 by a tournament on CV.

Deviations from the PlatEMO code (docs/algorithms-baselines.md, "CMOES"), each a
constructor argument: at the stage switch PlatEMO keeps P2/P3 but takes their tournament
fitness from a fresh even search (and P1's fitness sorted apart from P1), so the first
stage-two tournaments read misaligned fitness; here P2/P3 and their fitness come from
that even search together, and P1's fitness stays aligned (``switch_keeps_populations=
True`` restores PlatEMO). The promising region is drawn from the feasible members of the
P1 just selected; PlatEMO indexes the new P1 with the old P1's feasibility mask
(``stale_feasible_mask=True``). ``reference="platemo"`` sets both and ``normalise=False``
(:data:`PLATEMO_SETTINGS`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from math import ceil

import numpy as np

from tmopt.algorithms.base import Algorithm, check_choice, check_number
from tmopt.algorithms.mgsaea import AlgorithmStateError
from tmopt.algorithms.operators.survival import (
    environmental_selection,
    lexicographic_rank,
    nsga2_selection,
    spea2_fitness,
    truncation,
)
from tmopt.algorithms.operators.variation import de_offspring, ga_offspring, tournament
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.metrics.indicators import constraint_violation
from tmopt.problems.base import ExpensiveProblem

log = logging.getLogger(__name__)

OPERATORS = ("ga", "de")
#: ``reference``: "tmopt" (the fixes in the module docstring) or "platemo" (CMOES.m's
#: behaviour for each, :data:`PLATEMO_SETTINGS`).
REFERENCES = ("tmopt", "platemo")
#: What ``reference="platemo"`` sets (each can also be set alone to measure one fix).
PLATEMO_SETTINGS = {"switch_keeps_populations": True, "stale_feasible_mask": True,
                    "normalise": False}


@dataclass
class _Set:
    """Designs with their real objective and constraint values (rows aligned)."""

    X: np.ndarray
    F: np.ndarray
    G: np.ndarray

    @property
    def cv(self) -> np.ndarray:
        return constraint_violation(self.G)

    def take(self, idx) -> _Set:
        return _Set(self.X[idx], self.F[idx], self.G[idx])

    def __len__(self) -> int:
        return len(self.X)

    @staticmethod
    def join(*sets: _Set) -> _Set:
        return _Set(*(np.vstack([getattr(s, k) for s in sets]) for k in ("X", "F", "G")))


# ---- the even search (EvenSearch.m, GetLable.m) ---------------------------------------------
def promising(F: np.ndarray, F_feasible: np.ndarray) -> np.ndarray:
    """Mask of rows not Pareto-dominated by any row of ``F_feasible`` (GetLable.m).

    With no feasible reference solutions the whole objective space is promising.
    """
    if len(F_feasible) == 0:
        return np.ones(len(F), dtype=bool)
    no_worse = np.all(F_feasible[None, :, :] <= F[:, None, :], axis=2)
    better = np.any(F_feasible[None, :, :] < F[:, None, :], axis=2)
    return ~np.any(no_worse & better, axis=1)


def even_search(pop: _Set, F_feasible: np.ndarray, n: int, tau: float, max_cv: float,
                normalise: bool) -> tuple[_Set, np.ndarray, _Set, np.ndarray]:
    """P2, its SPEA2 fitness, P3 and its CV from ``pop`` (EvenSearch.m).

    P2: members of the promising region that are non-dominated there (SPEA2 fitness on
    the objectives < 1), cut to ``n`` by SPEA2 truncation. P3: members of the promising
    region with CV <= max_cv * (1 - tau)^2, cut to ``n`` likewise.
    """
    region = pop.take(np.flatnonzero(promising(pop.F, F_feasible)))
    fitness = spea2_fitness(region.F, normalise=normalise) if len(region) else np.zeros(0)
    p2 = _cut(np.flatnonzero(fitness < 1.0), region.F, n, normalise)
    cv = region.cv
    eps = max_cv * (1.0 - tau) ** 2
    p3 = _cut(np.flatnonzero(cv <= eps), region.F, n, normalise)
    return region.take(p2), fitness[p2], region.take(p3), cv[p3]


def _cut(idx: np.ndarray, F: np.ndarray, n: int, normalise: bool) -> np.ndarray:
    """``idx`` reduced to ``n`` rows by SPEA2 truncation on their objectives."""
    if len(idx) <= n:
        return idx
    return idx[~truncation(F[idx], len(idx) - n, normalise=normalise)]


# ---- the algorithm -------------------------------------------------------------------------
class CMOES(Algorithm):
    """CMOES (see the module docstring for parameters and the algorithm)."""

    name = "cmoes"

    def __init__(self, *, pop_size: int = 100, operator: str = "ga", stage_ratio: float = 0.2,
                 crossover_eta: float = 20.0, mutation_eta: float = 20.0,
                 normalise: bool = True, switch_keeps_populations: bool = False,
                 stale_feasible_mask: bool = False, reference: str = "tmopt") -> None:
        super().__init__(pop_size=pop_size)
        check_choice(self.name, "operator", operator, OPERATORS)
        self.reference = check_choice(self.name, "reference", reference, REFERENCES)
        if reference == "platemo":  # every documented fix undone (PLATEMO_SETTINGS)
            switch_keeps_populations = stale_feasible_mask = True
            normalise = False
        self.switch_keeps_populations = bool(switch_keeps_populations)
        self.stale_feasible_mask = bool(stale_feasible_mask)
        self.operator = operator
        self.stage_ratio = check_number(self.name, "stage_ratio", stage_ratio, 0.0, 1.0)
        self.crossover_eta = check_number(self.name, "crossover_eta", crossover_eta, 0.0)
        self.mutation_eta = check_number(self.name, "mutation_eta", mutation_eta, 0.0)
        self.normalise = bool(normalise)

    # ---- framework hooks ------------------------------------------------------------------
    def initial_sample_size(self, problem: ExpensiveProblem) -> int:
        """2N: P1 and P2 are initialised independently (CMOES.m)."""
        return 2 * self.pop_size

    def _setup(self) -> None:
        self.stage = 1
        self.p1 = self.p2 = self.p3 = None
        self._fit1 = self._fit2 = self._fit3 = None
        self._branch = 1     # stage of the offspring last asked for
        self._tau = 0.0      # gen / maxgen of the current stage-two generation
        self._max_cv = 0.0   # largest CV in [P1, P2, P3] at the start of that generation

    def info(self) -> dict:
        if self.p1 is None:
            return {"stage": self.stage}
        return {"stage": self.stage, "feasible_P1": int(np.sum(self.p1.cv == 0.0)),
                "P2": len(self.p2), "P3": len(self.p3)}

    # ---- ask ----------------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        n = self.pop_size
        if self.p1 is None:
            return self.rng.uniform(self.problem.xl, self.problem.xu, (2 * n, self.problem.n_var))
        gen, maxgen = ceil(self.n_evals / n), ceil(self.budget / n)
        # The condition is re-checked every generation (CMOES.m); the branch taken here is
        # remembered so the selection after the evaluations matches it.
        if np.all(self.p1.cv > 0.0) or gen <= self.stage_ratio * maxgen:
            self._branch = 1
            return self._stage_one_offspring()
        self._branch, self._tau = 2, gen / maxgen
        if self.stage == 1:
            self._switch_stage()
        return self._stage_two_offspring()

    def _stage_one_offspring(self) -> np.ndarray:
        n = self.pop_size
        mates1 = tournament(self._fit1, 2 * n, self.rng).reshape(2, n).T
        mates2 = tournament(self._fit2, 2 * n, self.rng).reshape(2, n).T
        return np.vstack([self._vary(self.p1.X, mates1, both=True),
                          self._vary(self.p2.X, mates2, both=False)])

    def _switch_stage(self) -> None:
        """First even search: P2/P3 and their fitness from [P1, P2, P3] (see module doc).

        ``switch_keeps_populations`` (CMOES.m): only the fitness comes from the even search;
        P2 and P3 stay as stage one left them, and P1's fitness is sorted (as
        EnvironmentalSelection.m returns it) while P1 is not, so tournaments read the
        fitness of other members (of the first len(fitness) members of P2 and P3)."""
        self.stage = 2
        union = _Set.join(self.p1, self.p2, self.p3)
        self._max_cv = float(union.cv.max())
        p2, self._fit2, p3, self._fit3 = even_search(
            union, self._feasible_front(), self.pop_size, self._tau, self._max_cv,
            self.normalise)
        self._fit1 = spea2_fitness(self.p1.F, self.p1.cv, normalise=self.normalise)
        if self.switch_keeps_populations:
            self._fit1 = np.sort(self._fit1)
            for pop, fit in ((self.p2, self._fit2), (self.p3, self._fit3)):
                if len(fit) > len(pop):  # MATLAB would index past P2/P3's end
                    raise AlgorithmStateError(f"algorithm {self.name}: {len(fit)} fitness "
                                              f"values for {len(pop)} members at the switch")
        else:
            self.p2, self.p3 = p2, p3
        log.info("%s: even search starts after %d evaluations", self.name, self.n_evals)

    def _stage_two_offspring(self) -> np.ndarray:
        self._max_cv = float(_Set.join(self.p1, self.p2, self.p3).cv.max())
        parts = []
        for pop, fit in ((self.p1, self._fit1), (self.p2, self._fit2), (self.p3, self._fit3)):
            if len(pop):
                mates = tournament(fit, 2 * len(pop), self.rng).reshape(2, len(pop)).T
                parts.append(self._vary(pop.X, mates, both=False))
        return np.vstack(parts)

    def _vary(self, X: np.ndarray, mates: np.ndarray, both: bool) -> np.ndarray:
        """Offspring of the mating pairs: GA (2 or 1 child per pair) or DE (1 per pair)."""
        p = self.problem
        if self.operator == "ga":
            kids = ga_offspring(X, mates, p.xl, p.xu, self.rng,
                                crossover_eta=self.crossover_eta, mutation_eta=self.mutation_eta)
            return kids if both else kids[: len(mates)]
        # PlatEMO's OperatorDE(Problem, P, P(pool first half), P(pool second half)): every
        # member is a base vector once, so DE gives one child per member in both stages.
        return de_offspring(X, X[mates[:, 0]], X[mates[:, 1]], p, self.rng,
                            mutation_eta=self.mutation_eta)

    # ---- tell ---------------------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        off = _Set(batch.X, batch.F, batch.G)
        if self.p1 is None:
            self._initialise(off)
        elif self._branch == 1:
            self._stage_one_selection(off)
        else:
            self._stage_two_selection(off)

    def _initialise(self, sample: _Set) -> None:
        n = self.pop_size
        first = sample.take(np.arange(min(n, len(sample))))
        second = sample.take(np.arange(len(first), len(sample)))
        keep, front, crowd = nsga2_selection(first.F, first.cv, n)
        self.p1, self._fit1 = first.take(keep), lexicographic_rank(front, -crowd)
        self.p2 = second if len(second) else first
        self._fit2 = spea2_fitness(self.p2.F, normalise=self.normalise)
        self.p3 = self.p1

    def _stage_one_selection(self, off: _Set) -> None:
        n = self.pop_size
        union1 = _Set.join(self.p1, off)
        keep, front, crowd = nsga2_selection(union1.F, union1.cv, n)
        self.p1, self._fit1 = union1.take(keep), lexicographic_rank(front, -crowd)
        union2 = _Set.join(self.p2, off)
        fitness = spea2_fitness(union2.F, normalise=self.normalise)
        keep = environmental_selection(fitness, union2.F, n, normalise=self.normalise)
        self.p2, self._fit2 = union2.take(keep), fitness[keep]
        self.p3 = self.p2

    def _stage_two_selection(self, off: _Set) -> None:
        n = self.pop_size
        old_feasible = self.p1.cv == 0.0
        union = _Set.join(self.p1, self.p2, self.p3, off)
        fitness = spea2_fitness(union.F, union.cv, normalise=self.normalise)
        keep = environmental_selection(fitness, union.F, n, normalise=self.normalise)
        self.p1, self._fit1 = union.take(keep), fitness[keep]
        self.p2, self._fit2, self.p3, self._fit3 = even_search(
            union, self._feasible_front(old_feasible if self.stale_feasible_mask else None),
            n, self._tau, self._max_cv, self.normalise)

    def _feasible_front(self, mask: np.ndarray | None = None) -> np.ndarray:
        """Objectives of P1's feasible members: they bound the promising region. ``mask``:
        PlatEMO's ``Population1(CV1 == 0)`` with CV1 of the P1 before the selection
        (``stale_feasible_mask``): the members of the new P1 at the old feasible places."""
        if mask is None:
            return self.p1.F[self.p1.cv == 0.0]
        m = min(len(mask), len(self.p1))
        return self.p1.F[:m][mask[:m]]

