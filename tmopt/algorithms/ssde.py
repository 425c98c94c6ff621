"""SSDE: self-organising surrogate-assisted non-dominated sorting differential evolution.

Tags: expensive, multi-/many-objective, constrained (CDP), surrogate-assisted (a
self-organising map predicts the offspring's objectives; only the offspring that survive
the predicted selection are evaluated for real). A Table 3 baseline of the seed paper.

Implements
    A. F. R. Araujo, L. R. C. Farias, A. R. C. Goncalves, "Self-organizing
    surrogate-assisted non-dominated sorting differential evolution", Swarm and
    Evolutionary Computation 91: 101703, 2024. Reference code: PlatEMO ``Algorithms/
    Multi-objective optimization/SSDE`` (``SSDE.m``, ``Operator.m``, ``Training.m``,
    written by the paper's second author), which this module follows; the paper's full
    text was not available here.

Parameters (keyword arguments; defaults: the constructor's signature):
    pop_size: population size N; the initial sample is N random designs.
    n_nodes: neurons of the 1-D map; None = N (PlatEMO's ``num_nodes``).
    eta0: initial SOM learning rate.
    sigma0: initial SOM neighbourhood radius in lattice units; None = N (PlatEMO).
    epochs: SOM training passes over the samples (Training.m).
    de_f, de_cr: DE/rand/1/bin scale factor and crossover rate (PlatEMO's
        OperatorDE defaults), followed by polynomial mutation (mutation_eta, 1/n_var).
    mutation_eta: polynomial mutation distribution index.
    max_idle: consecutive generations in which no child is predicted to survive
        before the algorithm stops proposing designs (PlatEMO would loop for ever).
    model_constraints: tmopt's extension, not in the paper or PlatEMO: the SOM
        also carries the constraint values, and a child's CV is that of its BMU instead
        of 0. Off by default (faithful); see the note on constraints below.
    reseed_first_nodes: PlatEMO's indexing of the re-seeding parents (the first nodes of
        the map instead of the winning nodes; :mod:`tmopt.algorithms.som`).
    reference: "tmopt" or "platemo" (sets ``reseed_first_nodes``, :data:`PLATEMO_SETTINGS`).

Algorithm (SSDE.m / Operator.m), one generation:

1. If at least N samples were collected since the last training, the SOM is trained on
   them (see :mod:`tmopt.algorithms.som`): each sample is [decision vector normalised to
   the bounds, real objective vector].
2. N children by DE: base vectors by binary tournament on the total violation
   CV = sum_k max(0, g_k), the two difference vectors drawn uniformly from the population.
3. Each child's objectives are the objective part of its best-matching node (BMU on the
   decision part); a child's constraints are taken as satisfied (CV = 0, Operator.m).
4. NSGA-II selection under the constrained-dominance principle of N from the population
   (real values) and the children (predicted values).
5. Only the children among the N survivors are evaluated for real (``ask`` returns just
   them, so a generation costs between 0 and N evaluations); they replace the parents
   that did not survive and become the next training samples. If no child survives, the
   population joins the samples (N of them, so the SOM is retrained) and the generation
   is repeated without real evaluations.

Constraints: with a child's CV taken as 0, every child beats every infeasible parent
under CDP, so while the population is infeasible the whole generation is evaluated and
replaces it; feasibility is then pursued only through the tournament on CV. SSDE was
designed for unconstrained expensive problems; this is how PlatEMO (and hence the seed
paper's Table 3) runs it on constrained ones.

Designs whose real evaluation failed stay in the population with their penalties (so the
selection pushes them out) but are never SOM training samples.
"""

from __future__ import annotations

import logging

import numpy as np

from tmopt.algorithms.base import (
    Algorithm,
    check_choice,
    check_int,
    check_number,
)
from tmopt.algorithms.operators.survival import nsga2_selection
from tmopt.algorithms.operators.variation import de_offspring, tournament
from tmopt.algorithms.som import SelfOrganisingMap
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.metrics.indicators import constraint_violation

log = logging.getLogger(__name__)

#: ``reference``: "tmopt" (the documented fix) or "platemo" (Training.m's behaviour).
REFERENCES = ("tmopt", "platemo")
#: What ``reference="platemo"`` sets.
PLATEMO_SETTINGS = {"reseed_first_nodes": True}


class SSDE(Algorithm):
    """SSDE (see the module docstring for parameters and the algorithm)."""

    name = "ssde"

    def __init__(self, *, pop_size: int = 100, n_nodes: int | None = None, eta0: float = 0.2,
                 sigma0: float | None = None, epochs: int = 50, de_f: float = 0.5,
                 de_cr: float = 1.0, mutation_eta: float = 20.0, max_idle: int = 100,
                 model_constraints: bool = False, reseed_first_nodes: bool = False,
                 reference: str = "tmopt") -> None:
        super().__init__(pop_size=pop_size)
        name = self.name
        self.reference = check_choice(name, "reference", reference, REFERENCES)
        self.reseed_first_nodes = bool(reseed_first_nodes) or reference == "platemo"
        self.n_nodes = None if n_nodes is None else check_int(name, "n_nodes", n_nodes, 1)
        self.eta0 = check_number(name, "eta0", eta0, 0.0, 1.0, low_open=True)
        self.sigma0 = None if sigma0 is None else check_number(name, "sigma0", sigma0, 0.0,
                                                               low_open=True)
        self.epochs = check_int(name, "epochs", epochs, 1)
        self.de_f = check_number(name, "de_f", de_f, 0.0, 2.0, low_open=True)
        self.de_cr = check_number(name, "de_cr", de_cr, 0.0, 1.0)
        self.mutation_eta = check_number(name, "mutation_eta", mutation_eta, 0.0)
        self.max_idle = check_int(name, "max_idle", max_idle, 1)
        self.model_constraints = bool(model_constraints)

    # ---- framework hooks -----------------------------------------------------------------
    def _setup(self) -> None:
        p = self.problem
        nodes = self.n_nodes or self.pop_size
        self._n_out = p.n_obj + (p.n_ieq_constr if self.model_constraints else 0)
        self.som = SelfOrganisingMap(nodes, p.n_var, self._n_out, self.eta0,
                                     self.sigma0 if self.sigma0 is not None else self.pop_size,
                                     self.epochs, self.rng,
                                     reseed_first_nodes=self.reseed_first_nodes)
        self.X = self.F = self.G = None
        self._failed = np.zeros(0, dtype=bool)  # population rows whose evaluation failed
        self._samples = np.zeros((0, p.n_var + self._n_out))
        self._replace: np.ndarray | None = None  # population rows the next batch replaces
        self._stalled = False
        self.n_trainings = 0
        self.last_survivors = 0

    def has_next(self) -> bool:
        return not self._stalled

    def info(self) -> dict:
        return {"survivors": self.last_survivors, "trainings": self.n_trainings}

    # ---- ask -----------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        p = self.problem
        if self.X is None:
            return self.rng.uniform(p.xl, p.xu, (self.pop_size, p.n_var))
        for _ in range(self.max_idle):
            if len(self._samples) >= self.pop_size:
                self.som.train(self._samples)
                self.n_trainings += 1
                self._samples = self._samples[:0]
            children, replace = self._generation()
            if len(children):
                self._replace, self.last_survivors = replace, len(children)
                return children
            # No child survives: the population joins the samples, which forces a
            # retraining, and the generation is repeated (Operator.m / SSDE.m).
            self._samples = np.vstack([self._samples, self._as_samples(
                self.X, self.F, self.G, self._failed)])
        log.warning("%s: no child predicted to survive in %d consecutive generations; "
                    "stopping after %d evaluations", self.name, self.max_idle, self.n_evals)
        self._stalled = True
        return np.zeros((0, p.n_var))

    def _generation(self) -> tuple[np.ndarray, np.ndarray]:
        """Children predicted to survive, and the population rows they would replace."""
        n = self.pop_size
        cv = constraint_violation(self.G)
        base = self.X[tournament(cv, n, self.rng)]
        r1 = self.X[self.rng.integers(0, n, n)]
        r2 = self.X[self.rng.integers(0, n, n)]
        kids = de_offspring(base, r1, r2, self.problem, self.rng, f=self.de_f, cr=self.de_cr,
                            mutation_eta=self.mutation_eta)
        predicted = self.som.predict(self._normalise(kids))
        m = self.problem.n_obj
        kid_cv = constraint_violation(predicted[:, m:]) if self.model_constraints else np.zeros(n)
        F = np.vstack([self.F, predicted[:, :m]])
        keep = nsga2_selection(F, np.concatenate([cv, kid_cv]), n)[0]
        out = np.setdiff1d(np.arange(n), keep)
        return kids[keep[keep >= n] - n], out

    def _normalise(self, X: np.ndarray) -> np.ndarray:
        return (X - self.problem.xl) / (self.problem.xu - self.problem.xl)

    def _as_samples(self, X: np.ndarray, F: np.ndarray, G: np.ndarray,
                    failed: np.ndarray) -> np.ndarray:
        """SOM training rows [normalised X, F (, G)] of the designs that did not fail."""
        ok = ~np.asarray(failed, dtype=bool)
        parts = [self._normalise(X[ok]), F[ok]] + ([G[ok]] if self.model_constraints else [])
        return np.hstack(parts)

    # ---- tell ----------------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        new = self._as_samples(batch.X, batch.F, batch.G, batch.failed)
        if self.X is None:
            self.X, self.F, self.G = batch.X.copy(), batch.F.copy(), batch.G.copy()
            self._failed = np.asarray(batch.failed, dtype=bool).copy()
            self._samples = new
            return
        rows = self._replace[: len(batch.X)]  # a prefix when the budget ran out
        self.X[rows], self.F[rows], self.G[rows] = batch.X, batch.F, batch.G
        self._failed[rows] = batch.failed
        self._samples = np.vstack([self._samples, new])
