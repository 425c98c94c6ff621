"""PEA: Pareto-based Kriging-assisted constrained EA with constrained probabilistic dominance.

Tags: expensive, constrained, multi-objective, surrogate-assisted (real-valued variables).

Implements
    Z. Zhang, Y. Wang, G. Sun, K. Tang, "Constrained probabilistic Pareto dominance for
    expensive constrained multiobjective optimization problems", IEEE TEVC 29(4), 2025
    (online 2024; reference code: PlatEMO ``Algorithms/Multi-objective optimization/PEA``,
    written from, not translated).

Parameters (keyword arguments; defaults, PlatEMO's, in the signature of :class:`PEA`):
    pop_size: N, the size of the initial Latin-hypercube sample and of the population.
    wmax: surrogate-only generations per iteration.
    mu: real evaluations per iteration (at most: designs already evaluated are dropped).
    crossover_eta, mutation_eta: SBX and polynomial mutation distribution indices.
    normalise: the last front's truncation on min-max normalised objectives (False =
        PlatEMO's raw distances).
    surrogate: zero-argument factory of :class:`~tmopt.surrogates.base.Surrogate` (its
        predictive standard deviation is used); None = the GP.

The constrained probabilistic Pareto dominance (CPPD, NDSort_CPPD.m): with predictive
means f and variances s^2 of the objectives, g and t^2 of the constraints,

    P_k(i < j) = Phi((f_jk - f_ik) / sqrt(s_ik^2 + s_jk^2))  (i better in objective k),
    LFP_i     = min_c Phi(-g_ic / t_ic)                      (i feasible, weakest constraint),
    i CPPD-dominates j  <=>  P_k(i < j) LFP_i >= P_k(j < i) LFP_j for every k, > for one.

Fronts: repeatedly, the remaining designs with the fewest CPPD dominators among the
remaining form the next front (CPPD need not be transitive, so "none" may not exist).
Real values have zero variance: P_k is 1, 0 or 1/2 (tie) and LFP 1 or 0.

Algorithm (PEA.m): (1) N LHS designs form the database and the population P. (2) Fit one
model of the objectives and one of the constraints on the database. (3) ``wmax``
generations from P on the predictions: SBX pairs the first half of the population with the
second, mutation, then CPPD fronts select N (a last front that is the first is cut by
SPEA2's truncation, a later one by greedy farthest-point selection). (4) Candidates: the
final population's designs not yet evaluated; ``mu`` by CPPD fronts, the last front by
farthest distance (normalised objectives) from a reference set -- the database's first
CDP front if at least N designs are feasible, else its best CDP fronts up to N designs --
and the candidates already chosen. (5) Evaluate; P = N best of the database by CDP fronts
(last front as in 3).

Deviations from PlatEMO (docs/algorithms-frontier.md, "PEA"): one multi-output model of
the objectives and one of the constraints from the ``surrogate`` group (PlatEMO: one
Kriging with a linear trend per output); a zero-variance tie counts as 1/2 (PlatEMO: 0/0
= NaN makes such pairs mutually non-dominated; ``nan_ties=True``); when every candidate
is already evaluated, ``mu`` random designs are sent (PlatEMO evaluates nothing and
searches again from the same models, which can repeat forever; ``random_fallback=False``
does so, up to :data:`REPEATED_SEARCHES` searches, then falls back); failed designs leave
the training data. ``reference="platemo"`` sets both and ``normalise=False``
(:data:`PLATEMO_SETTINGS`).
"""

from __future__ import annotations

import logging

import numpy as np
from pymoo.operators.sampling.lhs import LHS
from scipy.spatial.distance import cdist
from scipy.stats import norm

from tmopt.algorithms.base import (
    Algorithm,
    check_choice,
    check_int,
    check_number,
    check_surrogate_factory,
)
from tmopt.algorithms.mgsaea import (
    AlgorithmStateError,
    SurrogateFactory,
    default_surrogate_factory,
)
from tmopt.algorithms.operators.constraints import cdp_sort
from tmopt.algorithms.operators.survival import farthest_points, truncation
from tmopt.algorithms.operators.variation import already_evaluated, ga_offspring, unique_rows
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.metrics.indicators import constraint_violation
from tmopt.surrogates.base import Surrogate

log = logging.getLogger(__name__)

#: ``reference``: "tmopt" (the fixes in the module docstring) or "platemo" (PEA.m's
#: behaviour for each, :data:`PLATEMO_SETTINGS`).
REFERENCES = ("tmopt", "platemo")
#: What ``reference="platemo"`` sets (each can also be set alone to measure one fix).
PLATEMO_SETTINGS = {"nan_ties": True, "random_fallback": False, "normalise": False}
#: With ``random_fallback=False``: searches from the same models before random designs
#: are sent after all (PEA.m would search for ever; a run must end).
REPEATED_SEARCHES = 20


def better_probability(F: np.ndarray, var: np.ndarray) -> np.ndarray:
    """``P[i, j, k]``: probability that i is better (smaller) than j in objective k,
    ``Phi((f_jk - f_ik) / sqrt(var_ik + var_jk))``; 1/2 for a zero-variance tie."""
    diff = F[None, :, :] - F[:, None, :]
    sd = np.sqrt(var[:, None, :] + var[None, :, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        p = norm.cdf(diff / sd)
    exact = sd == 0
    p[exact] = np.where(diff[exact] > 0, 1.0, np.where(diff[exact] < 0, 0.0, 0.5))
    return p


def feasible_probability(G: np.ndarray, var: np.ndarray) -> np.ndarray:
    """LFP_i = min over constraints of Phi(-g / t) (1 without constraints; with zero
    variance 1 if g <= 0 else 0)."""
    if G.shape[1] == 0:
        return np.ones(len(G))
    sd = np.sqrt(var)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = norm.cdf(-G / sd)
    exact = sd == 0
    p[exact] = (G[exact] <= 0).astype(float)
    return p.min(axis=1)


def cppd_matrix(F: np.ndarray, f_var: np.ndarray, G: np.ndarray,
                g_var: np.ndarray, nan_ties: bool = False) -> np.ndarray:
    """``D[i, j]``: i CPPD-dominates j (module docstring). ``nan_ties``: NDSort_CPPD.m's
    0/0 -- a pair tied with zero variance in some objective has NaN probabilities there,
    every comparison with them is false, and neither design dominates the other."""
    lfp = feasible_probability(G, g_var)
    p = better_probability(F, f_var)
    mine = p * lfp[:, None, None]                     # P_k(i < j) LFP_i
    theirs = np.swapaxes(p, 0, 1) * lfp[None, :, None]  # P_k(j < i) LFP_j
    dom = (mine >= theirs).all(axis=2) & (mine > theirs).any(axis=2)
    if nan_ties:
        exact_tie = (f_var[:, None, :] + f_var[None, :, :] == 0) \
            & (F[:, None, :] == F[None, :, :])
        dom &= ~exact_tie.any(axis=2)
    return dom


def cppd_fronts(dom: np.ndarray, n_sort: int) -> np.ndarray:
    """Front numbers (1, 2, ...; ``inf`` for rows left unsorted) until at least ``n_sort``
    rows are sorted: each front is the rows with the fewest dominators among the rest."""
    n = len(dom)
    front = np.full(n, np.inf)
    dom = dom.copy()
    k = 0
    while np.isfinite(front).sum() < min(n_sort, n):
        k += 1
        rest = np.flatnonzero(~np.isfinite(front))
        count = dom[np.ix_(rest, rest)].sum(axis=0)
        members = rest[count == count.min()]
        front[members] = k
        dom[members, :] = False
    return front


class PEA(Algorithm):
    """PEA (see the module docstring)."""

    name = "pea"

    def __init__(self, *, pop_size: int = 100, wmax: int = 20, mu: int = 5,
                 crossover_eta: float = 20.0, mutation_eta: float = 20.0,
                 normalise: bool = True, nan_ties: bool = False, random_fallback: bool = True,
                 reference: str = "tmopt", surrogate: SurrogateFactory | None = None) -> None:
        super().__init__(pop_size=pop_size)
        name = self.name
        self.reference = check_choice(name, "reference", reference, REFERENCES)
        if reference == "platemo":  # every documented fix undone (PLATEMO_SETTINGS)
            nan_ties, random_fallback, normalise = True, False, False
        self.nan_ties = bool(nan_ties)
        self.random_fallback = bool(random_fallback)
        self.wmax = check_int(name, "wmax", wmax, 1)
        self.mu = check_int(name, "mu", mu, 1)
        self.crossover_eta = check_number(name, "crossover_eta", crossover_eta, 0.0)
        self.mutation_eta = check_number(name, "mutation_eta", mutation_eta, 0.0)
        self.normalise = bool(normalise)
        self._factory = check_surrogate_factory(name, surrogate)

    def _setup(self) -> None:
        self._X = np.zeros((0, self.problem.n_var))  # the database (successful designs)
        self._F = np.zeros((0, self.problem.n_obj))
        self._G = np.zeros((0, self.problem.n_ieq_constr))
        self._pop = np.zeros(0, dtype=int)  # P: rows of the database
        self._seen = np.zeros((0, self.problem.n_var))
        self._surrogate = self._factory or default_surrogate_factory()
        self._obj_model: Surrogate | None = None
        self._con_model: Surrogate | None = None
        self._random_batches = 0
        self._repeated_searches = 0

    def summary(self) -> dict:
        return {"random_batches": self._random_batches,
                "repeated_searches": self._repeated_searches}

    # ---- ask -------------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        if len(self._seen) == 0:
            X = LHS().do(self.problem, self.pop_size, random_state=self.rng).get("X")
            return self._remember(X)
        self._fit()
        for attempt in range(1 if self.random_fallback else REPEATED_SEARCHES):
            if attempt:  # PEA.m: nothing evaluated, search again from the same models
                self._repeated_searches += 1
            C = self._candidates(*self._search())
            if len(C):
                return self._remember(C)
        log.warning("%s: every candidate is already evaluated; sending %d random designs",
                    self.name, self.mu)
        self._random_batches += 1
        return self._remember(self.rng.uniform(self.problem.xl, self.problem.xu,
                                               size=(self.mu, self.problem.n_var)))

    def _remember(self, X: np.ndarray) -> np.ndarray:
        X = np.clip(X, self.problem.xl, self.problem.xu)
        X = X[unique_rows(X)]
        self._seen = np.vstack([self._seen, X])
        return X

    def _fit(self) -> None:
        if self._obj_model is None:
            self._obj_model = self._surrogate()
            self._con_model = self._surrogate() if self.problem.n_ieq_constr else None
        self._obj_model.fit(self._X, self._F)
        if self._con_model is not None:
            self._con_model.fit(self._X, self._G)

    def _predict(self, X: np.ndarray):
        f, fs = (np.asarray(a, dtype=float) for a in self._obj_model.predict(X))
        if self._con_model is None:
            empty = np.zeros((len(X), 0))
            return f, fs**2, empty, empty
        g, gs = (np.asarray(a, dtype=float) for a in self._con_model.predict(X))
        return f, fs**2, g, gs**2

    def _search(self):
        """Step 3: ``wmax`` generations from P on the predictions, CPPD selection."""
        p = self._pop
        X, F, G = self._X[p], self._F[p], self._G[p]
        fv, gv = np.zeros_like(F), np.zeros_like(G)
        n = len(X)
        for _ in range(self.wmax):
            half = n // 2
            mates = np.column_stack([np.arange(half), half + np.arange(half)])
            off = ga_offspring(X, mates, self.problem.xl, self.problem.xu, self.rng,
                               crossover_eta=self.crossover_eta,
                               mutation_eta=self.mutation_eta)
            f, f_v, g, g_v = self._predict(off)
            X, F, G = np.vstack([X, off]), np.vstack([F, f]), np.vstack([G, g])
            fv, gv = np.vstack([fv, f_v]), np.vstack([gv, g_v])
            keep = self._select(F, cppd_fronts(cppd_matrix(F, fv, G, gv, self.nan_ties), n),
                                n)
            X, F, G, fv, gv = X[keep], F[keep], G[keep], fv[keep], gv[keep]
        return X, F, fv, G, gv

    def _select(self, F: np.ndarray, front: np.ndarray, n: int) -> np.ndarray:
        """Indices (ascending) of ``n`` rows: whole fronts, the last one cut by truncation
        (when it is the first) or by farthest points from the fronts before it."""
        last = np.nanmax(np.where(np.isfinite(front), front, np.nan))
        before = front < last
        tied = np.flatnonzero(front == last)
        room = n - int(before.sum())
        if len(tied) <= room:
            return np.sort(np.concatenate([np.flatnonzero(before), tied]))
        if last == 1:
            gone = truncation(F[tied], len(tied) - room, normalise=self.normalise)
            kept = tied[~gone]
        else:
            rows = np.concatenate([np.flatnonzero(before), tied])
            D = cdist(F[rows], F[rows])
            chosen = np.zeros(len(rows), dtype=bool)
            chosen[: int(before.sum())] = True
            grown = farthest_points(D, chosen, n)
            kept = tied[grown[int(before.sum()):]]
        return np.sort(np.concatenate([np.flatnonzero(before), kept]))

    def _candidates(self, X, F, fv, G, gv) -> np.ndarray:
        """Step 4: ``mu`` not-yet-evaluated designs by CPPD fronts and distance (none if
        every candidate is already evaluated)."""
        new = ~self._already_seen(X)
        X, F, fv, G, gv = X[new], F[new], fv[new], G[new], gv[new]
        if len(X) <= self.mu:
            return X
        lo = np.vstack([self._F, F]).min(axis=0)
        span = np.maximum(np.vstack([self._F, F]).max(axis=0) - lo, 1e-9)
        Fn, fvn = (F - lo) / span, fv / span**2
        front = cppd_fronts(cppd_matrix(Fn, fvn, G, gv, self.nan_ties), self.mu)
        last = np.nanmax(np.where(np.isfinite(front), front, np.nan))
        chosen = front < last
        tied = np.flatnonzero(front == last)
        room = self.mu - int(chosen.sum())
        if len(tied) <= room:
            chosen[tied] = True
            return X[chosen]
        ref = np.vstack([self._reference_set(lo, span), Fn[chosen]])
        rows = np.vstack([ref, Fn[tied]])
        mask = np.zeros(len(rows), dtype=bool)
        mask[: len(ref)] = True
        grown = farthest_points(cdist(rows, rows), mask, len(ref) + room)
        chosen[tied[grown[len(ref):]]] = True
        return X[chosen]

    def _reference_set(self, lo: np.ndarray, span: np.ndarray) -> np.ndarray:
        """The database's first CDP front if N designs are feasible, else its best CDP
        fronts until they hold N designs (normalised objectives)."""
        cv = constraint_violation(self._G)
        front = cdp_sort(self._F, cv)
        if (cv <= 0).sum() >= self.pop_size:
            keep = front == front.min()
        else:
            order = np.sort(np.unique(front))
            counts = np.cumsum([np.sum(front == f) for f in order])
            last = order[min(np.searchsorted(counts, self.pop_size), len(order) - 1)]
            keep = front <= last
        return (self._F[keep] - lo) / span

    def _already_seen(self, X: np.ndarray) -> np.ndarray:
        return already_evaluated(X, self._seen, self.problem.xl, self.problem.xu)

    # ---- tell ------------------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        ok = ~np.asarray(batch.failed, dtype=bool)
        self._X = np.vstack([self._X, batch.X[ok]])
        self._F = np.vstack([self._F, batch.F[ok]])
        self._G = np.vstack([self._G, batch.G[ok]])
        if len(self._X) < 2:
            raise AlgorithmStateError(
                f"algorithm {self.name}: only {len(self._X)} successful evaluation(s); "
                f"at least 2 are needed to fit surrogates")
        n = min(self.pop_size, len(self._X))
        front = cdp_sort(self._F, constraint_violation(self._G)).astype(float) + 1.0
        order = np.sort(front)
        front[front > order[n - 1]] = np.inf  # sorted only as far as N needs (NDSort)
        self._pop = self._select(self._F, front, n)
