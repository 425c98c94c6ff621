"""KTS: Kriging-assisted constrained multi-objective search with two search modes.

Tags: expensive, constrained, multi-objective, surrogate-assisted (real-valued variables).

Implements
    Z. Song, H. Wang, B. Xue, M. Zhang, Y. Jin, "Balancing objective optimization and
    constraint satisfaction in expensive constrained evolutionary multiobjective
    optimization", IEEE TEVC 28(5), 2024 (reference code: PlatEMO
    ``Algorithms/Multi-objective optimization/KTS``, written from, not translated). Its
    unconstrained mode is KTA2 (Song, Wang, He, Jin, "A Kriging-assisted two-archive
    evolutionary algorithm for expensive many-objective optimization", IEEE TEVC 25(6),
    2021); its constrained mode is a surrogate-assisted two-population
    search in the manner of CCMO (Tian et al., IEEE TEVC 25(1), 2021).

Parameters (keyword arguments; their defaults, PlatEMO's, are written once, in the
signature of :class:`KTS`):
    pop_size: N, the size of the initial Latin-hypercube sample and of every archive and
        population (CA, DA, P1, P2).
    tau, phi: the switch thresholds on the correlation r between convergence and
        violation of the best evaluated designs: r < -phi -> constrained search; r >= tau
        -> unconstrained search; in between, either with probability 1/2.
    n_elite: mu of the paper, the number of best-converged evaluated designs (plus one)
        whose correlation decides the mode.
    wmax: surrogate-only generations per iteration.
    n_infill: real evaluations per iteration (at most; duplicates are dropped).
    uncertainty_share: the share of CDA drawn at random for each uncertainty pick
        (KTA2's phi).
    kappa: the scaling factor of the I_eps+ indicator fitness (IBEA, 0.05).
    crossover_eta, mutation_eta: SBX and polynomial mutation distribution indices.
    normalise: SPEA2 density and truncation on min-max normalised objectives (False =
        PlatEMO's raw distances; the house default, as MGSAEA, docs/algorithms-mgsaea.md).
    surrogate: zero-argument factory of :class:`~tmopt.surrogates.base.Surrogate`; None =
        :class:`tmopt.surrogates.gp.GPSurrogate`.

Algorithm (one iteration: choose the mode, fit, ``wmax`` surrogate generations, sample,
evaluate), following KTS.m:

1. Initial sample: N LHS designs, evaluated. A1 = every evaluated design; CA
   (convergence archive, I_eps+ truncation to N), DA (diversity archive: non-dominated,
   extremes then farthest points in the L_p norm, p = 1/M), P1 (SPEA2 on the objectives)
   and P2 (SPEA2 under CDP) start from it.
2. Mode: sort A1 by the I_eps+ fitness; r = Pearson correlation of 1/F and the total
   violation over the ``n_elite`` + 1 best-converged designs; constrained if r < -phi,
   unconstrained if r >= tau, else a coin flip. (A positive r means the best-converged
   designs also violate least: objectives and constraints agree.)
3. Models: objectives on A1 (every iteration); constraints (one output per constraint)
   on DA + CA + P2 (designs rounded to 1e-4 of the range and de-duplicated), refitted
   only in constrained mode, else kept from the last fit (as PlatEMO).
4. ``wmax`` generations on the predictions, from CCA = CA, CP2 = P2 and CDA = DA1
   (unconstrained) or P1 (constrained):
   unconstrained (KTA2): parents = dominance-tournament winners of CCA paired with
   random members of CDA (SBX only) and N random members of CCA (mutation only);
   constrained (CCMO-like): N tournament winners on CP2's constrained SPEA2 fitness and
   N on CDA's unconstrained one, SBX + mutation.
   Then CCA = I_eps+ truncation of CCA + offspring; CDA = DA update (unconstrained) or
   SPEA2 (constrained); CP2 = constrained SPEA2 on the predicted constraints.
5. Infill (``n_infill`` designs): unconstrained: KTA2's adaptive sampling on the
   not-yet-evaluated members of CCA and CDA -- convergence sampling (I_eps+ truncation
   of CCA) when CCA is significantly closer to the ideal point than CDA, else
   uncertainty sampling (largest mean predicted variance among random subsets of CDA)
   when CDA's pure diversity is below the real DA's, else diversity sampling (farthest
   points of CDA from the real DA); constrained: k-means of CP2's predicted objectives
   into ``n_infill`` clusters, from each the best by CDP strength + closeness to the
   feasible non-dominated members of P2.
6. Evaluate; update A1, CA, DA1, P1, P2 with the real values.

Deviations from PlatEMO (docs/algorithms-frontier.md, "KTS"): the convergence test is
Wilcoxon's rank-sum test (PlatEMO pairs the two unordered sets by index in a signed-rank
test and skips it unless they have equal sizes); the I_eps+ deletion update uses the
removed column's own scale for every column (PlatEMO mixes the scales); the DA update of
the predictions keeps the extreme designs (PlatEMO keeps a design chosen by a random
objective's index); designs already evaluated are never proposed in constrained mode
either; k-means runs on normalised predicted objectives; failed designs leave the
training data. Each of these is a constructor argument (``paired_convergence_test``,
``mixed_scale_deletion``, ``da_update``, ``skip_evaluated``, ``kmeans_normalised``, and
``normalise`` for SPEA2's distances); ``reference="platemo"`` sets all of them to KTS.m's
behaviour (:data:`PLATEMO_SETTINGS`).
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import numpy as np
from pymoo.operators.sampling.lhs import LHS
from scipy.cluster.vq import kmeans2
from scipy.spatial.distance import cdist
from scipy.stats import mannwhitneyu, rankdata, wilcoxon

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
from tmopt.algorithms.operators.constraints import dominance_matrix
from tmopt.algorithms.operators.survival import (
    environmental_selection,
    farthest_points,
    normalised,
    spea2_fitness,
)
from tmopt.algorithms.operators.variation import (
    already_evaluated,
    ga_offspring,
    polynomial_mutation,
    tournament,
    unique_rows,
)
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.metrics.indicators import constraint_violation
from tmopt.surrogates.base import Surrogate

log = logging.getLogger(__name__)

UNCONSTRAINED, CONSTRAINED = "unconstrained", "constrained"
#: ``reference``: "tmopt" (the fixes in the module docstring) or "platemo" (KTS.m's
#: behaviour for each, :data:`PLATEMO_SETTINGS`).
REFERENCES = ("tmopt", "platemo")
#: DA updates: "tmopt" (extremes, then L_p farthest points on objectives normalised over the
#: non-dominated rows) or "platemo" (UpdateDA.m on raw objectives for real designs;
#: K_UpdateDA.m for predictions: the row at a random objective index, normalised over all
#: rows before the non-dominated filter).
DA_UPDATES = ("tmopt", "platemo")
#: What ``reference="platemo"`` sets (each can also be set alone to measure one fix).
PLATEMO_SETTINGS = {"paired_convergence_test": True, "mixed_scale_deletion": True,
                    "da_update": "platemo", "skip_evaluated": False,
                    "kmeans_normalised": False, "normalise": False}
#: KTS.m adds a real design to A1 (the objective models' data) only if it lies farther
#: than this (Euclidean, raw decision space) from every design already there.
A1_DUPLICATE_DISTANCE = 1e-5


@dataclass
class Designs:
    """Designs with objective and constraint values (real or predicted) and the
    predicted variance of each objective (zero for real values)."""

    X: np.ndarray
    F: np.ndarray
    G: np.ndarray
    var: np.ndarray

    @staticmethod
    def real(X: np.ndarray, F: np.ndarray, G: np.ndarray) -> Designs:
        return Designs(X, F, G, np.zeros_like(F))

    def take(self, idx) -> Designs:
        return Designs(self.X[idx], self.F[idx], self.G[idx], self.var[idx])

    def __len__(self) -> int:
        return len(self.X)

    def __add__(self, other: Designs) -> Designs:
        return Designs(*(np.concatenate([a, b]) for a, b in zip(
            (self.X, self.F, self.G, self.var), (other.X, other.F, other.G, other.var))))

    @property
    def cv(self) -> np.ndarray:
        return constraint_violation(self.G)


# ---- I_eps+ indicator fitness (IBEA: Zitzler & Kuenzli, PPSN VIII, 2004) --------------------
def _eps_matrix(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """I[i, j] = max_k (f_ik - f_jk) on min-max normalised objectives, and each column's
    scale c_j = max_i |I[i, j]| (1 where it is 0)."""
    Fn = normalised(F)
    eps = (Fn[:, None, :] - Fn[None, :, :]).max(axis=2)
    scale = np.abs(eps).max(axis=0)
    return eps, np.where(scale > 0, scale, 1.0)


def eps_fitness(F: np.ndarray, kappa: float) -> np.ndarray:
    """IBEA fitness F(j) = -sum_{i != j} exp(-I(i, j) / (c_j kappa)) (<= 0; nearer 0 is
    better: a design that others barely dominate)."""
    eps, scale = _eps_matrix(F)
    return 1.0 - np.exp(-eps / scale[None, :] / kappa).sum(axis=0)


def eps_truncation(F: np.ndarray, n: int, kappa: float,
                   mixed_scale: bool = False) -> np.ndarray:
    """Indices (ascending) of ``n`` survivors: repeatedly delete the worst fitness and
    give its contribution back to the others (IBEA's environmental selection).

    ``mixed_scale``: PlatEMO's UpdateCA.m / K_UpdateCA.m / Adaptive_sampling.m give back
    exp(-I(x, j) / c_x / kappa) with the deleted design x's scale c_x for every column j
    (the fitness was built with each column's own c_j)."""
    if len(F) <= n:
        return np.arange(len(F))
    eps, scale = _eps_matrix(F)
    contrib = np.exp(-eps / scale[None, :] / kappa)
    fit = 1.0 - contrib.sum(axis=0)
    alive = np.ones(len(F), dtype=bool)
    for _ in range(len(F) - n):
        worst = np.flatnonzero(alive)[np.argmin(fit[alive])]
        alive[worst] = False
        fit += np.exp(-eps[worst] / scale[worst] / kappa) if mixed_scale else contrib[worst]
    return np.flatnonzero(alive)


# ---- diversity (KTA2) ------------------------------------------------------------------------
def lp_distances(A: np.ndarray, B: np.ndarray, p: float) -> np.ndarray:
    """(sum_k |a_k - b_k|^p)^(1/p) between rows (p < 1 allowed: KTA2's p = 1/M)."""
    return (np.abs(A[:, None, :] - B[None, :, :]) ** p).sum(axis=2) ** (1.0 / p)


def diversity_archive(F: np.ndarray, n: int, p: float) -> np.ndarray:
    """KTA2's DA update: indices of the non-dominated rows; above ``n``, the extreme ones
    (smallest and largest of each objective) and then the farthest in the L_p norm of the
    objectives min-max normalised over the non-dominated rows."""
    nd = np.flatnonzero(~dominance_matrix(F).any(axis=0))
    if len(nd) <= n:
        return nd
    Fn = normalised(F[nd])
    chosen = np.zeros(len(nd), dtype=bool)
    chosen[np.argmin(Fn, axis=0)] = True
    chosen[np.argmax(Fn, axis=0)] = True
    if chosen.sum() > n:  # more extremes than room (n < 2M): keep n of them
        extra = np.flatnonzero(chosen)[n:]
        chosen[extra] = False
    chosen = farthest_points(lp_distances(Fn, Fn, p), chosen, n)
    return nd[np.flatnonzero(chosen)]


def platemo_diversity_archive(F: np.ndarray, n: int, p: float, rng: np.random.Generator,
                              predicted: bool) -> np.ndarray:
    """PlatEMO's DA updates: indices of the non-dominated rows; above ``n``, farthest
    points in the L_p norm grown from

    * real designs (UpdateDA.m): the extreme rows, ``n`` of them kept at random if they
      are more, distances on the raw objectives;
    * predictions (K_UpdateDA.m): the row at a random *objective index* (a random one of
      the first M non-dominated rows), distances on objectives min-max normalised over
      all rows of ``F`` before the non-dominated filter.
    """
    nd = np.flatnonzero(~dominance_matrix(F).any(axis=0))
    if len(nd) <= n:
        return nd
    chosen = np.zeros(len(nd), dtype=bool)
    if predicted:
        Fd = normalised(F)[nd]
        # (an index past the rows only when N < M: MATLAB would grow the mask; wrap instead)
        chosen[rng.permutation(F.shape[1])[0] % len(nd)] = True
    else:
        Fd = F[nd]
        chosen[np.argmin(Fd, axis=0)] = True
        chosen[np.argmax(Fd, axis=0)] = True
        if chosen.sum() > n:
            chosen[rng.permutation(np.flatnonzero(chosen))[: chosen.sum() - n]] = False
    chosen = farthest_points(lp_distances(Fd, Fd, p), chosen, n)
    return nd[np.flatnonzero(chosen)]


def paired_signed_rank_converges(d_ca: np.ndarray, d_da: np.ndarray) -> bool:
    """Cal_Convergence.m's decision given the two distance lists (paired by index):
    Wilcoxon's signed-rank test of d_ca - d_da (PlatEMO's signrank_new: differences below
    eps(x) + eps(y) and NaN dropped; exact for n <= 15, else the normal approximation
    without continuity correction), two-sided at 0.05, and convergence only when the rank
    sum of the negative differences (CA closer) is at least that of the positive ones."""
    diff = np.asarray(d_ca, dtype=float) - np.asarray(d_da, dtype=float)
    tiny = np.spacing(np.abs(d_ca)) + np.spacing(np.abs(d_da))
    keep = np.isfinite(diff) & (np.abs(diff) >= tiny)
    diff = diff[keep]
    n = len(diff)
    if n == 0:
        return False
    ranks = rankdata(np.abs(diff))
    r_neg = ranks[diff < 0].sum()
    r_pos = n * (n + 1) / 2 - r_neg
    pvalue = wilcoxon(diff, zero_method="wilcox", correction=False,
                      method="exact" if n <= 15 else "approx").pvalue
    return bool(pvalue <= 0.05 and r_neg >= r_pos)


def pure_diversity(F: np.ndarray, p: float = 0.1) -> float:
    """Pure diversity (Wang, Jin, Yao, IEEE Trans. Cybern. 47(6), 2017) with the L_0.1 distance,
    by the greedy linkage of KTA2: each step links the design farthest from its nearest
    neighbour (skipping links inside one connected group) and adds that distance."""
    n = len(F)
    if n < 2:
        return 0.0
    D = lp_distances(F, F, p)
    np.fill_diagonal(D, np.inf)
    linked = np.eye(n, dtype=bool)
    score = 0.0
    for _ in range(n - 1):
        while True:
            J = np.argmin(D, axis=1)
            d = D[np.arange(n), J]
            i = int(np.argmax(d))
            j = int(J[i])
            if not np.isfinite(d[i]):
                return score
            if D[j, i] != -np.inf:
                D[j, i] = np.inf
            if D[i, j] != -np.inf:
                D[i, j] = np.inf
            if not _connected(linked, i, j):
                break
        linked[i, j] = linked[j, i] = True
        D[i, :] = -np.inf
        score += float(d[i])
    return score


def _connected(link: np.ndarray, i: int, j: int) -> bool:
    reach = link[i].copy()
    while not reach[j]:
        grown = link[reach].any(axis=0) | reach
        if np.array_equal(grown, reach):
            return False
        reach = grown
    return True


class KTS(Algorithm):
    """KTS (see the module docstring for parameters and the algorithm)."""

    name = "kts"

    def __init__(self, *, pop_size: int = 100, tau: float = 0.6, phi: float = 0.2,
                 n_elite: int = 20, wmax: int = 10, n_infill: int = 5,
                 uncertainty_share: float = 0.1, kappa: float = 0.05,
                 crossover_eta: float = 20.0, mutation_eta: float = 20.0,
                 normalise: bool = True, paired_convergence_test: bool = False,
                 mixed_scale_deletion: bool = False, da_update: str = "tmopt",
                 skip_evaluated: bool = True, kmeans_normalised: bool = True,
                 reference: str = "tmopt", surrogate: SurrogateFactory | None = None) -> None:
        super().__init__(pop_size=pop_size)
        name = self.name
        self.reference = check_choice(name, "reference", reference, REFERENCES)
        check_choice(name, "da_update", da_update, DA_UPDATES)
        if reference == "platemo":  # every documented fix undone (PLATEMO_SETTINGS)
            paired_convergence_test = mixed_scale_deletion = True
            skip_evaluated = kmeans_normalised = normalise = False
            da_update = "platemo"
        self.paired_convergence_test = bool(paired_convergence_test)
        self.mixed_scale_deletion = bool(mixed_scale_deletion)
        self.da_update = da_update
        self.skip_evaluated = bool(skip_evaluated)
        self.kmeans_normalised = bool(kmeans_normalised)
        self.tau = check_number(name, "tau", tau, -1.0, 1.0)
        self.phi = check_number(name, "phi", phi, -1.0, 1.0)
        self.n_elite = check_int(name, "n_elite", n_elite, 2)
        self.wmax = check_int(name, "wmax", wmax, 1)
        self.n_infill = check_int(name, "n_infill", n_infill, 1)
        self.uncertainty_share = check_number(name, "uncertainty_share", uncertainty_share,
                                              0.0, 1.0, low_open=True)
        self.kappa = check_number(name, "kappa", kappa, 0.0, low_open=True)
        self.crossover_eta = check_number(name, "crossover_eta", crossover_eta, 0.0)
        self.mutation_eta = check_number(name, "mutation_eta", mutation_eta, 0.0)
        self.normalise = bool(normalise)
        self._factory = check_surrogate_factory(name, surrogate)

    # ---- framework hooks -----------------------------------------------------------------
    def _setup(self) -> None:
        self._p = 1.0 / self.problem.n_obj
        self._all: Designs | None = None  # A1: every successful real evaluation
        self._seen = np.zeros((0, self.problem.n_var))
        self._surrogate = self._factory or default_surrogate_factory()
        self._obj_model: Surrogate | None = None
        self._con_model: Surrogate | None = None
        self.mode: str | None = None
        self.last_r: float | None = None
        self.sampling: str | None = None
        self._counts: dict[str, int] = {}

    def info(self) -> dict:
        out: dict = {}
        if self.mode is not None:
            out["mode"] = self.mode
            out["sampling"] = self.sampling
        if self.last_r is not None:
            out["r"] = f"{self.last_r:.2f}"
        return out

    def summary(self) -> dict:
        """Iterations per search mode and per sampling strategy."""
        return {"iterations": dict(sorted(self._counts.items()))}

    # ---- ask -------------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        if self._all is None:
            X = LHS().do(self.problem, self.pop_size, random_state=self.rng).get("X")
            return self._remember(X)
        self.mode = self._choose_mode()
        da = self._da if self.mode == UNCONSTRAINED else self._p1
        self._fit(da)
        cca, cda, cp2 = self._search(da)
        X = self._sample(cca, cda, cp2, da)
        for key in (self.mode, f"{self.mode}:{self.sampling}"):
            self._counts[key] = self._counts.get(key, 0) + 1
        return self._remember(X)

    def _remember(self, X: np.ndarray) -> np.ndarray:
        X = np.clip(X, self.problem.xl, self.problem.xu)
        X = X[unique_rows(X)]
        self._seen = np.vstack([self._seen, X])
        return X

    def _choose_mode(self) -> str:
        """Step 2: the correlation of convergence and violation among the best designs."""
        fit = eps_fitness(self._all.F, self.kappa)
        q = 1.0 / np.minimum(fit, -1e-300)  # more negative = better converged
        best = np.argsort(q, kind="stable")[: self.n_elite + 1]
        cv = self._all.cv[best]
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.corrcoef(q[best], cv)[0, 1] if len(best) > 1 else np.nan
        self.last_r = None if not np.isfinite(r) else float(r)
        # NaN (e.g. every best design feasible: no conflict to resolve) -> unconstrained,
        # as the comparisons in KTS.m fall through with NaN.
        if self.last_r is not None and self.last_r < -self.phi:
            return CONSTRAINED
        if self.last_r is None or self.last_r >= self.tau:
            return UNCONSTRAINED
        return UNCONSTRAINED if self.rng.random() < 0.5 else CONSTRAINED

    def _fit(self, da: Designs) -> None:
        """Step 3: objective models on A1; constraint models in constrained mode (and the
        first time) on DA + CA + P2."""
        if self._obj_model is None:
            self._obj_model = self._surrogate()
        self._obj_model.fit(self._all.X, self._all.F)
        if self.problem.n_ieq_constr and (self._con_model is None or self.mode == CONSTRAINED):
            data = da + self._ca + self._p2
            span = self.problem.xu - self.problem.xl
            keep = unique_rows((data.X - self.problem.xl) / span, decimals=4)
            if self._con_model is None:
                self._con_model = self._surrogate()
            self._con_model.fit(data.X[keep], data.G[keep])

    def _predict(self, X: np.ndarray) -> Designs:
        mean, std = self._obj_model.predict(X)
        F = np.asarray(mean, dtype=float)
        var = np.asarray(std, dtype=float) ** 2
        if self._con_model is None:
            G = np.zeros((len(X), 0))
        else:
            G = np.asarray(self._con_model.predict_mean(X), dtype=float)
        return Designs(X, F, G, var)

    def _spea2(self, s: Designs, n: int, constrained: bool) -> Designs:
        fit = spea2_fitness(s.F, s.cv if constrained else None, normalise=self.normalise)
        return s.take(environmental_selection(fit, s.F, n, normalise=self.normalise))

    def _search(self, da: Designs) -> tuple[Designs, Designs, Designs]:
        """Step 4: ``wmax`` generations on the predictions."""
        cca, cda, cp2 = self._ca, da, self._p2
        N = self.pop_size
        for _ in range(self.wmax):
            off = self._offspring(cca, cda, cp2)
            pop = self._predict(off)
            cca = cca + pop
            cca = cca.take(self._eps_truncation(cca.F, N))
            cda = cda + pop
            cda = cda.take(self._diversity_archive(cda.F, predicted=True)) \
                if self.mode == UNCONSTRAINED else self._spea2(cda, N, constrained=False)
            cp2 = self._spea2(cp2 + pop, N, constrained=True)
        return cca, cda, cp2

    def _offspring(self, cca: Designs, cda: Designs, cp2: Designs) -> np.ndarray:
        N, xl, xu, rng = self.pop_size, self.problem.xl, self.problem.xu, self.rng
        eta = {"crossover_eta": self.crossover_eta, "mutation_eta": self.mutation_eta}
        if self.mode == UNCONSTRAINED:  # KTA2's mating: CA x DA crossover, CA mutation
            half = (N + 1) // 2
            a, b = rng.integers(len(cca), size=(2, half))
            dom = dominance_matrix(cca.F)
            winners = np.where(dom[a, b], a, b)
            partners = rng.integers(len(cda), size=half)
            parents = np.vstack([cca.X[winners], cda.X[partners]])
            mates = np.column_stack([np.arange(half), half + np.arange(half)])
            crossed = ga_offspring(parents, mates, xl, xu, rng, mutation=False, **eta)
            mutated = polynomial_mutation(cca.X[rng.integers(len(cca), size=N)], xl, xu, rng,
                                          mutation_eta=self.mutation_eta)
            return np.vstack([crossed, mutated])
        out = []
        for s, constrained in ((cp2, True), (cda, False)):
            fit = spea2_fitness(s.F, s.cv if constrained else None, normalise=self.normalise)
            pairs = (N + 1) // 2
            mates = tournament(fit, 2 * pairs, rng).reshape(pairs, 2)
            out.append(ga_offspring(s.X, mates, xl, xu, rng, **eta)[:N])
        return np.vstack(out)

    # ---- step 5: infill --------------------------------------------------------------------
    def _sample(self, cca: Designs, cda: Designs, cp2: Designs, da: Designs) -> np.ndarray:
        if self.mode == UNCONSTRAINED:
            cca, cda = cca.take(~self._already_seen(cca.X)), cda.take(~self._already_seen(cda.X))
            X = self._adaptive_sampling(cca, cda, da)
        else:
            X = self._constrained_sampling(cp2.take(~self._already_seen(cp2.X))
                                           if self.skip_evaluated else cp2)
        if len(X) == 0:
            log.warning("%s: every surrogate candidate is already evaluated; sending %d "
                        "random designs", self.name, self.n_infill)
            self.sampling = "random"
            X = self.rng.uniform(self.problem.xl, self.problem.xu,
                                 size=(self.n_infill, self.problem.n_var))
        return X

    def _adaptive_sampling(self, cca: Designs, cda: Designs, da: Designs) -> np.ndarray:
        """KTA2's convergence / uncertainty / diversity sampling (Adaptive_sampling.m)."""
        mu = self.n_infill
        if len(cda) <= mu or self._ca_converges_better(cca, cda):
            self.sampling = "convergence"
            return cca.X[self._eps_truncation(cca.F, mu)] if len(cca) else cda.X
        if pure_diversity(cda.F) < pure_diversity(da.F):
            self.sampling = "uncertainty"
            size = int(np.ceil(self.uncertainty_share * len(cda)))
            picks = []
            for _ in range(mu):
                subset = self.rng.permutation(len(cda))[:size]
                picks.append(subset[np.argmax(cda.var[subset].mean(axis=1))])
            return cda.X[np.unique(picks)]
        self.sampling = "diversity"
        both = normalised(np.vstack([da.F, cda.F]))
        chosen = np.zeros(len(both), dtype=bool)
        chosen[: len(da)] = True
        grown = farthest_points(lp_distances(both, both, self._p), chosen, len(da) + mu)
        return cda.X[np.flatnonzero(grown[len(da):])]

    def _ca_converges_better(self, cca: Designs, cda: Designs) -> bool:
        """Whether CCA's distances to the ideal point are significantly (rank-sum test,
        0.05) smaller than CDA's (Cal_Convergence.m; distance = sqrt of the summed
        normalised objectives, as KTA2). ``paired_convergence_test``: Cal_Convergence.m
        itself (:func:`paired_signed_rank_converges`; "not converging" unless the sizes
        are equal; objectives translated by the ideal point z and divided by
        max(f - z) - z, z subtracted twice as there; a negative sum under the root,
        complex in MATLAB, is NaN here and dropped)."""
        if self.paired_convergence_test:
            if len(cca) != len(cda):
                return False
            both = np.vstack([cca.F, cda.F])
            ideal = both.min(axis=0)
            shifted = both - ideal
            with np.errstate(invalid="ignore", divide="ignore"):
                dist = np.sqrt((shifted / (shifted.max(axis=0) - ideal)).sum(axis=1))
            return paired_signed_rank_converges(dist[: len(cca)], dist[len(cca):])
        if len(cca) < 2 or len(cda) < 2:
            return False
        both = np.vstack([cca.F, cda.F])
        ideal = both.min(axis=0)
        span = both.max(axis=0) - ideal
        dist = np.sqrt(((both - ideal) / np.where(span > 0, span, 1.0)).sum(axis=1))
        d_ca, d_da = dist[: len(cca)], dist[len(cca):]
        if np.ptp(dist) == 0:
            return False
        return bool(mannwhitneyu(d_ca, d_da, alternative="less").pvalue < 0.025)

    def _constrained_sampling(self, cp2: Designs) -> np.ndarray:
        """KCCMO_sampling.m: cluster CP2's predicted objectives into ``n_infill`` groups;
        from each the design of least CDP strength sum + nearness to P2's feasible
        non-dominated real designs (all of P2 while none is feasible)."""
        self.sampling = "clusters"
        mu = self.n_infill
        if len(cp2) <= mu:
            return cp2.X
        p2 = self._p2
        feasible = p2.cv <= 0
        ref = p2.F[feasible] if feasible.any() else p2.F
        ref = ref[~dominance_matrix(ref).any(axis=0)]
        dom = dominance_matrix(cp2.F, cp2.cv)
        strength = dom.sum(axis=1).astype(float)
        fitness = dom.T.astype(float) @ strength + 1.0 / (cdist(cp2.F, ref).min(axis=1) + 2.0)
        with warnings.catch_warnings():  # an empty cluster only gives one design fewer
            warnings.simplefilter("ignore")
            _, label = kmeans2(normalised(cp2.F) if self.kmeans_normalised else cp2.F, mu,
                               minit="++", rng=self.rng)
        picks = [members[np.argmin(fitness[members])]
                 for k in range(mu) if len(members := np.flatnonzero(label == k))]
        return cp2.X[np.sort(picks)]

    def _eps_truncation(self, F: np.ndarray, n: int) -> np.ndarray:
        return eps_truncation(F, n, self.kappa, mixed_scale=self.mixed_scale_deletion)

    def _diversity_archive(self, F: np.ndarray, predicted: bool) -> np.ndarray:
        if self.da_update == "platemo":
            return platemo_diversity_archive(F, self.pop_size, self._p, self.rng, predicted)
        return diversity_archive(F, self.pop_size, self._p)

    def _already_seen(self, X: np.ndarray) -> np.ndarray:
        return already_evaluated(X, self._seen, self.problem.xl, self.problem.xu)

    # ---- step 6: tell ----------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        ok = ~np.asarray(batch.failed, dtype=bool)
        new = Designs.real(batch.X[ok], batch.F[ok], batch.G[ok])
        N = self.pop_size
        if self._all is None:
            self._all = new
            self._ca = new.take(self._eps_truncation(new.F, N))
            self._da = new.take(self._diversity_archive(new.F, predicted=False))
            self._p1 = self._spea2(new, N, constrained=False)
            self._p2 = self._spea2(new, N, constrained=True)
        else:
            # re-sent designs (skip_evaluated=False) stay out of A1 as in KTS.m, but join
            # CA, DA, P1 and P2 as copies
            far = cdist(new.X, self._all.X).min(axis=1) > A1_DUPLICATE_DISTANCE \
                if not self.skip_evaluated else np.ones(len(new), dtype=bool)
            self._all = self._all + new.take(far)
            ca = self._ca + new
            self._ca = ca.take(self._eps_truncation(ca.F, N))
            da = self._da + new
            self._da = da.take(self._diversity_archive(da.F, predicted=False))
            self._p1 = self._spea2(self._p1 + new, N, constrained=False)
            self._p2 = self._spea2(self._p2 + new, N, constrained=True)
        if len(self._all) < 2:
            raise AlgorithmStateError(
                f"algorithm {self.name}: only {len(self._all)} successful evaluation(s); "
                f"at least 2 are needed to fit surrogates")
