"""MGSAEA, MGSAEA-IPC and MGSAEA*: multigranularity surrogate-assisted constrained EAs.

Tags: expensive, constrained, multi-objective, surrogate-assisted (real-valued variables).

Implements
    Y. Zhang, H. Jiang, Y. Tian, H. Ma, X. Zhang, "Multigranularity surrogate modeling for
    evolutionary multiobjective optimization with expensive constraints", IEEE TNNLS
    35(3): 2956-2968, 2024 (MGSAEA; reference code: PlatEMO ``Algorithms/Multi-objective
    optimization/MGSAEA``), and its extension with individual progressive constraints of
    the seed paper (aerospace 12(8): 673, 2025, Sec. 3.2.2, Fig. 3): MGSAEA-IPC, and the
    ablation MGSAEA* of its Table 3.

Parameters (keyword arguments; their defaults, PlatEMO's and the seed paper's settings,
are written once, in the signature of :class:`MGSAEA` and :class:`MGSAEAIPC`):
    pop_size: size N of the elite set (PlatEMO's ``Problem.N``, its ``Archive``; the seed
        paper's "population"). Not the run's archive of every real evaluation, from which
        tmopt takes the final set (docs/decisions.md, "Final set").
    wmax: surrogate-only generations per iteration.
    mu: real evaluations per iteration.
    gap: iterations over which the ideal point's change rate mc is measured.
    threshold: stage two starts once mc <= threshold (PlatEMO's ``lambda``).
    sigma: small positive number in the denominator of mc (seed paper Eq. 20).
    n_init: size of the Latin-hypercube initial sample, which is also the size NI of the
        real and the surrogate population; None = 11 * n_var - 1 (MGSAEA.m).
    max_iter: iterations (of ``mu`` real evaluations each) after the initial sample, the
        seed paper's "iterations"; None = until the budget is spent.
    crossover_eta, mutation_eta: SBX (probability 1) and polynomial mutation (1/n_var per
        variable) distribution indices, PlatEMO's ``OperatorGA`` defaults.
    normalise: SPEA2 density and truncation on min-max normalised objectives (False =
        PlatEMO's raw distances).
    surrogate: zero-argument factory of :class:`~tmopt.surrogates.base.Surrogate`; None =
        :class:`tmopt.surrogates.gp.GPSurrogate`.
    ungrouped (MGSAEA-IPC only): what IPC does on a problem that declares no constraint
        groups: "first" = constraint 0 is the key individual's (the same as the suites'
        ``constraint_groups=split``), "error" = refuse.

Algorithm (one iteration = fit surrogates, ``wmax`` surrogate generations, ``mu`` real
evaluations), following MGSAEA.m:

1. Initial sample: LHS of NI designs, evaluated for real; they form the population; the
   elite set is the population reduced to N by constrained SPEA2 selection.
2. Stage one. The three variants differ only here (the models and the ranking):
   MGSAEA: objectives only (M models, SPEA2, constraints ignored, as PlatEMO);
   MGSAEA-IPC: objectives + the key individual's constraints (M + N_kn models, one per
   key constraint as in Fig. 3, CDP on their violation);
   MGSAEA*: objectives + every constraint (M + N_con models, CDP) -- IPC without the
   key-individual priority (Table 3 note).
3. Stage switch: the ideal point of the population is recorded every iteration; once
   more than ``gap`` iterations are recorded, mc (seed paper Eq. 20) <= threshold
   switches to stage two for good.
4. Stage two (all variants): the granularity follows the population
   (:func:`~tmopt.algorithms.operators.constraints.choose_granularity`): coarse = objectives
   + one model of the normalised total violation, CDP; fine = objectives + one model per not
   fully satisfied constraint, their summed violation an extra objective of SPEA2;
   objectives = objective models only, SPEA2 (TNNLS paper Sec. III).
5. In both stages: ``wmax`` generations of binary tournament (SPEA2 fitness), SBX + PM
   and SPEA2 environmental selection on the predictions; then the ``mu`` designs chosen
   by the same selection from the final surrogate population are evaluated for real;
   the population keeps its NI - mu best (selection of the current stage) plus the new
   ones; the elite set takes the new ones and is cut back to N by constrained SPEA2.

Quirks of the reference fixed here (details in docs/algorithms-mgsaea.md): |.| in the
denominator of mc; violations scaled by the population's largest violation instead of
min-max (min-max maps the least-violating infeasible design to "feasible"); designs
already evaluated are never sent for re-evaluation; failed designs leave the training
data; objectives normalised for SPEA2 distances.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from pymoo.operators.sampling.lhs import LHS

from tmopt.algorithms.base import (
    Algorithm,
    AlgorithmConfigError,
    check_choice,
    check_int,
    check_surrogate_factory,
)
from tmopt.algorithms.operators.constraints import choose_granularity
from tmopt.algorithms.operators.stage import change_rate
from tmopt.algorithms.operators.survival import environmental_selection, spea2_fitness
from tmopt.algorithms.operators.variation import (
    already_evaluated,
    ga_offspring,
    tournament,
    unique_rows,
)
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.metrics.indicators import constraint_violation
from tmopt.problems.base import ConstraintGroup, ExpensiveProblem
from tmopt.surrogates.base import Surrogate

log = logging.getLogger(__name__)

SurrogateFactory = Callable[[], Surrogate]


#: ``reference``: "tmopt" (the fixes of docs/algorithms-mgsaea.md, "Quirks of the
#: references fixed here") or "platemo" (PlatEMO's MGSAEA.m behaviour for each of them).
REFERENCES = ("tmopt", "platemo")
#: What ``reference="platemo"`` sets (each can also be set alone to measure one fix):
#: quirk 1 ``abs_change_rate`` (mc without |.| in the denominator), quirk 2 ``sigma``
#: (PlatEMO's delta 1e-6), quirk 3 ``violation_scaling`` (NormalizeCV's min-max),
#: quirk 4 ``skip_evaluated`` (already evaluated designs may be sent again), quirk 5
#: ``normalise`` (raw objective distances in SPEA2).
PLATEMO_SETTINGS = {"abs_change_rate": False, "sigma": 1e-6, "violation_scaling": "minmax",
                    "skip_evaluated": False, "normalise": False}


class AlgorithmStateError(RuntimeError):
    """The algorithm cannot continue (e.g. too few successful evaluations to fit models)."""


@dataclass
class _Set:
    """Designs with their real objective and constraint values."""

    X: np.ndarray
    F: np.ndarray
    G: np.ndarray

    def take(self, idx) -> _Set:
        return _Set(self.X[idx], self.F[idx], self.G[idx])

    def __len__(self) -> int:
        return len(self.X)

    @staticmethod
    def join(a: _Set, b: _Set) -> _Set:
        return _Set(np.vstack([a.X, b.X]), np.vstack([a.F, b.F]), np.vstack([a.G, b.G]))


def violation_scale(G: np.ndarray) -> np.ndarray:
    """Positive per-constraint scale: the largest violation in ``G`` (else max |g|, else 1).

    Dividing by it keeps a zero violation zero (feasibility is preserved), unlike the
    min-max normalisation of PlatEMO's ``NormalizeCV``.
    """
    if G.shape[1] == 0:
        return np.ones(0)
    worst = np.max(np.maximum(G, 0.0), axis=0) if len(G) else np.zeros(G.shape[1])
    mag = np.max(np.abs(G), axis=0) if len(G) else np.zeros(G.shape[1])
    return np.where(worst > 0.0, worst, np.where(mag > 0.0, mag, 1.0))


@dataclass(frozen=True)
class ModelPlan:
    """What one iteration models and how solutions are ranked.

    Attributes:
        granularity: Label for progress lines: stage one "objectives" / "key" / "all",
            stage two "coarse" / "fine" / "objectives".
        mode: Ranking on predictions: "pareto" (SPEA2 on objectives), "cdp" (SPEA2 under
            constrained dominance), "fine" (SPEA2 on objectives + summed violation).
        con: Constraint columns modelled.
        aggregate: One model of their summed scaled violation (coarse) instead of one
            model per constraint.
        pop_mode, pop_con: Ranking of the real population when it is updated.
        scale, offset, clip: Constraint values enter the models as
            ``(g - offset) / scale`` (``max(0, g)`` in place of g when ``clip``): tmopt
            divides by the largest violation (:func:`violation_scale`, offset 0, signed);
            PlatEMO min-max scales the violation (:func:`minmax_scaling`).
    """

    granularity: str
    mode: str
    con: tuple[int, ...] = ()
    aggregate: bool = False
    pop_mode: str = "pareto"
    pop_con: tuple[int, ...] = ()
    scale: np.ndarray = field(default_factory=lambda: np.ones(0), compare=False)
    offset: np.ndarray | None = field(default=None, compare=False)
    clip: bool = False

    @property
    def n_outputs_extra(self) -> int:
        return 1 if self.aggregate else len(self.con)

    def targets(self, F: np.ndarray, G: np.ndarray) -> np.ndarray:
        """Training outputs: objectives, then the scaled constraint(s)."""
        if not self.con:
            return F
        C = self.scaled(G, self.con)
        if self.aggregate:
            C = np.maximum(C, 0.0).sum(axis=1, keepdims=True)
        return np.hstack([F, C])

    def scaled(self, G: np.ndarray, con: tuple[int, ...]) -> np.ndarray:
        """Columns ``con`` of ``G`` as the models see them (see the class attributes)."""
        cols = list(con)
        V = np.maximum(G[:, cols], 0.0) if self.clip else G[:, cols]
        if self.offset is not None:
            V = V - self.offset[cols]
        return V / self.scale[cols]

    def split(self, P: np.ndarray, n_obj: int) -> tuple[np.ndarray, np.ndarray]:
        """Predicted objectives and predicted total violation (clipped at zero)."""
        return P[:, :n_obj], np.maximum(P[:, n_obj:], 0.0).sum(axis=1)


def minmax_scaling(G: np.ndarray) -> dict:
    """PlatEMO's ``NormalizeCV``: ``(max(0, g) - min) / (max - min)`` per constraint over
    ``G`` (0 where max = min). It maps the least-violating design to 0, i.e. "feasible",
    even when every design violates the constraint (docs/algorithms-mgsaea.md, quirk 3).
    Returns the :class:`ModelPlan` fields ``scale``, ``offset``, ``clip``."""
    V = np.maximum(G, 0.0)
    lo = V.min(axis=0) if len(G) else np.zeros(G.shape[1])
    span = (V.max(axis=0) - lo) if len(G) else np.zeros(G.shape[1])
    return {"scale": np.where(span > 0, span, np.inf), "offset": lo, "clip": True}


def plan_scaling(G: np.ndarray, minmax: bool = False) -> dict:
    """The :class:`ModelPlan` scaling fields for constraint values ``G``: tmopt's
    (:func:`violation_scale`) or, with ``minmax``, PlatEMO's (:func:`minmax_scaling`)."""
    return minmax_scaling(G) if minmax else {"scale": violation_scale(G)}


def granularity_plan(granularity: str, unsatisfied: np.ndarray, G: np.ndarray,
                     minmax: bool = False) -> ModelPlan:
    """The stage-two plan of a granularity (TNNLS Sec. III) for the real population's
    constraint values ``G``: "coarse" (one model of the total scaled violation, CDP),
    "fine" (one model per constraint in ``unsatisfied``, summed violation an extra
    objective) or "objectives" (objective models only, SPEA2; the real population
    by CDP). ``minmax``: PlatEMO's violation scaling."""
    sc = plan_scaling(G, minmax)
    every = tuple(range(G.shape[1]))
    if granularity == "coarse":
        return ModelPlan("coarse", "cdp", every, True, "cdp", every, **sc)
    if granularity == "fine":
        con = tuple(int(i) for i in unsatisfied)
        return ModelPlan("fine", "fine", con, False, "fine", every, **sc)
    if granularity == "objectives":
        return ModelPlan("objectives", "pareto", (), False, "cdp", every, **sc)
    raise ValueError(f"unknown granularity {granularity!r}")


def rank_fitness(mode: str, F: np.ndarray, cv: np.ndarray, normalise: bool) -> np.ndarray:
    """SPEA2 fitness under one of the plan's ranking modes (PlatEMO's ``status``)."""
    if mode == "pareto":
        return spea2_fitness(F, normalise=normalise)
    if mode == "cdp":
        return spea2_fitness(F, cv, normalise=normalise)
    if mode == "fine":
        return spea2_fitness(np.hstack([F, cv[:, None]]), normalise=normalise)
    raise ValueError(f"unknown ranking mode {mode!r}")


class MGSAEA(Algorithm):
    """MGSAEA (see the module docstring for parameters and the algorithm)."""

    name = "mgsaea"
    #: Constraints of stage one: "none" (MGSAEA), "key" (MGSAEA-IPC), "all" (MGSAEA*).
    stage_one_constraints = "none"

    def __init__(self, *, pop_size: int = 100, wmax: int = 20, mu: int = 5, gap: int = 20,
                 threshold: float = 1e-3, sigma: float = 1e-3, n_init: int | None = None,
                 max_iter: int | None = 100, crossover_eta: float = 20.0,
                 mutation_eta: float = 20.0, normalise: bool = True,
                 violation_scaling: str = "max", skip_evaluated: bool = True,
                 abs_change_rate: bool = True, reference: str = "tmopt",
                 surrogate: SurrogateFactory | None = None) -> None:
        super().__init__(pop_size=pop_size)
        name = self.name
        check_choice(name, "reference", reference, REFERENCES)
        if violation_scaling not in ("max", "minmax"):
            raise AlgorithmConfigError(f"algorithm {name}: violation_scaling must be 'max' "
                                       f"or 'minmax', got {violation_scaling!r}")
        self.reference = reference
        if reference == "platemo":  # every documented fix undone (PLATEMO_SETTINGS)
            sigma, normalise = PLATEMO_SETTINGS["sigma"], PLATEMO_SETTINGS["normalise"]
            violation_scaling = PLATEMO_SETTINGS["violation_scaling"]
            skip_evaluated = PLATEMO_SETTINGS["skip_evaluated"]
            abs_change_rate = PLATEMO_SETTINGS["abs_change_rate"]
        self.violation_scaling = violation_scaling
        self.skip_evaluated = bool(skip_evaluated)
        self.abs_change_rate = bool(abs_change_rate)
        self.wmax = check_int(name, "wmax", wmax, 0)
        self.mu = check_int(name, "mu", mu, 1)
        self.gap = check_int(name, "gap", gap, 1)
        self.threshold = self._positive("threshold", threshold)
        self.sigma = self._positive("sigma", sigma)
        self.n_init = None if n_init is None else check_int(name, "n_init", n_init, 2)
        self.max_iter = None if max_iter is None else check_int(name, "max_iter", max_iter, 0)
        self.crossover_eta = self._positive("crossover_eta", crossover_eta)
        self.mutation_eta = self._positive("mutation_eta", mutation_eta)
        self.normalise = bool(normalise)
        self._factory = check_surrogate_factory(self.name, surrogate)

    # ---- argument checks ------------------------------------------------------------------
    def _positive(self, label: str, value) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) \
                or not np.isfinite(value) or value <= 0:
            raise AlgorithmConfigError(f"algorithm {self.name}: {label} must be a positive "
                                       f"finite number, got {value!r}")
        return float(value)

    # ---- framework hooks -------------------------------------------------------------------
    def initial_sample_size(self, problem: ExpensiveProblem) -> int:
        """NI = 11 * D - 1 (MGSAEA.m) unless ``n_init`` is given."""
        return self.n_init if self.n_init is not None else 11 * int(problem.n_var) - 1

    def _setup(self) -> None:
        self._ni = self.initial_sample_size(self.problem)
        self._stage_one_con = self.stage_one_indices(self.problem)
        if self.stage_one_constraints == "key" and not declares_groups(self.problem) \
                and self.problem.n_ieq_constr > 1:
            _say_fallback_once(self.name, self.problem.name)
        self._pop: _Set | None = None
        self._elite: _Set | None = None
        self._seen = np.zeros((0, self.problem.n_var))  # every design sent, failed ones too
        self._ideal: list[np.ndarray] = []
        self.stage = 1
        self.iteration = 0
        self.last_mc: float | None = None
        self._mc_trace: list[float] = []  # mc of every iteration that measured it
        self._switch_iteration: int | None = None
        self._granularities: list[str] = []  # "stage<k>:<granularity>" of every iteration
        self._plan: ModelPlan | None = None
        self._models: dict[tuple, Surrogate] = {}
        self._surrogate = self._factory or default_surrogate_factory()

    def stage_one_indices(self, problem: ExpensiveProblem) -> tuple[int, ...]:
        """Constraint columns considered in stage one (none for plain MGSAEA)."""
        return ()

    def has_next(self) -> bool:
        return self.max_iter is None or self._pop is None or self.iteration < self.max_iter

    def info(self) -> dict:
        out: dict = {"stage": self.stage}
        if self._plan is not None:
            out["granularity"] = self._plan.granularity
            out["models"] = self.problem.n_obj + self._plan.n_outputs_extra
        if self.last_mc is not None:
            out["mc"] = f"{self.last_mc:.3g}"
        return out

    def summary(self) -> dict:
        """Stage reached, the iteration whose models were the first of stage two (None:
        never), and the change rate mc (Eq. 20) over the iterations that measured it.

        ``stage_two_possible`` says whether the run had more than ``gap`` iterations, the
        least before mc can be measured at all. ``granularity_iterations`` counts the
        iterations of each plan, e.g. ``{"stage1:key": 38, "stage2:coarse": 2}``.
        """
        trace = np.asarray(self._mc_trace, dtype=float)
        mc = None if not len(trace) else {
            "n": int(len(trace)), "first": float(trace[0]), "last": float(trace[-1]),
            "min": float(trace.min()), "median": float(np.median(trace)),
            "max": float(trace.max())}
        labels, counts = np.unique(self._granularities, return_counts=True)
        return {"stage_reached": int(self.stage), "switch_iteration": self._switch_iteration,
                "iterations": int(self.iteration), "gap": self.gap,
                "threshold": self.threshold, "stage_two_possible": self.iteration > self.gap,
                "mc": mc, "granularity_iterations": {str(k): int(v)
                                                     for k, v in zip(labels, counts)}}

    # ---- ask --------------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        if self._pop is None:
            X = LHS().do(self.problem, self._ni, random_state=self.rng).get("X")
            return self._remember(X)
        self._update_stage()
        self._plan = self._make_plan()
        self._granularities.append(f"stage{self.stage}:{self._plan.granularity}")
        model = self._fit(self._plan)
        X, P = self._surrogate_search(self._plan, model)
        self.iteration += 1
        return self._remember(self._choose_infill(self._plan, X, P))

    def _remember(self, X: np.ndarray) -> np.ndarray:
        X = np.clip(X, self.problem.xl, self.problem.xu)
        self._seen = np.vstack([self._seen, X])
        return X

    def _update_stage(self) -> None:
        """Record the ideal point; switch to stage two once mc <= threshold (Eq. 20)."""
        self._ideal.append(self._pop.F.min(axis=0))
        if self.stage == 1 and len(self._ideal) > self.gap:
            self.last_mc = change_rate(self._ideal[-1], self._ideal[-1 - self.gap],
                                       sigma=self.sigma, absolute=self.abs_change_rate)
            self._mc_trace.append(self.last_mc)
            if self.last_mc <= self.threshold:
                self.stage = 2
                self._switch_iteration = self.iteration + 1
                log.info("%s: stage two after %d iterations (mc=%.3g <= %.3g)", self.name,
                         self.iteration, self.last_mc, self.threshold)

    def _make_plan(self) -> ModelPlan:
        G = self._pop.G
        minmax = self.violation_scaling == "minmax"
        if self.stage == 1:
            con = self._stage_one_con
            label = {"none": "objectives", "key": "key", "all": "all"}[
                self.stage_one_constraints]
            mode = "cdp" if con else "pareto"
            return ModelPlan(label, mode, con, False, mode, con, **plan_scaling(G, minmax))
        return granularity_plan(*choose_granularity(G), G, minmax=minmax)

    def _fit(self, plan: ModelPlan) -> Surrogate:
        """Fit one (multi-output) surrogate of every modelled output at once.

        One model object is kept per set of outputs, so a surrogate that warm-starts its
        hyperparameters (as PlatEMO keeps THETA per output) reuses the last fit of the
        same outputs.
        """
        key = (plan.granularity, plan.con, plan.aggregate)
        model = self._models.get(key)
        if model is None:
            model = self._models[key] = self._surrogate()
        model.fit(self._pop.X, plan.targets(self._pop.F, self._pop.G))
        return model

    def _predict(self, model: Surrogate, X: np.ndarray) -> np.ndarray:
        # Only the mean is used (as PlatEMO's predictor); predict_mean skips the std.
        mean_only = getattr(model, "predict_mean", None)
        mean = mean_only(X) if mean_only is not None else model.predict(X)[0]
        return np.asarray(mean, dtype=float)

    def _fitness(self, plan: ModelPlan, P: np.ndarray) -> np.ndarray:
        F, cv = plan.split(P, self.problem.n_obj)
        return rank_fitness(plan.mode, F, cv, self.normalise)

    def _select(self, plan: ModelPlan, P: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Indices of ``n`` survivors (duplicates in predicted objectives dropped) + fitness."""
        m = self.problem.n_obj
        idx = unique_rows(P[:, :m])
        fit = self._fitness(plan, P[idx])
        keep = environmental_selection(fit, P[idx, :m], n, normalise=self.normalise)
        return idx[keep], fit[keep]

    def _surrogate_search(self, plan: ModelPlan, model: Surrogate):
        """``wmax`` generations on the surrogates (SPEA2 with the plan's ranking)."""
        X = self._pop.X
        P = self._predict(model, X)
        fit = self._fitness(plan, P)
        n_pairs = max(self._ni // 2, 1)
        for _ in range(self.wmax):
            mates = tournament(fit, 2 * n_pairs, self.rng).reshape(n_pairs, 2)
            off = self._variation(X, mates)
            X = np.vstack([X, off])
            P = np.vstack([P, self._predict(model, off)])
            keep, fit = self._select(plan, P, self._ni)
            X, P = X[keep], P[keep]
        return X, P

    def _variation(self, X: np.ndarray, mates: np.ndarray) -> np.ndarray:
        return ga_offspring(X, mates, self.problem.xl, self.problem.xu, self.rng,
                            crossover_eta=self.crossover_eta, mutation_eta=self.mutation_eta)

    def _choose_infill(self, plan: ModelPlan, X: np.ndarray, P: np.ndarray) -> np.ndarray:
        """The ``mu`` designs to evaluate: SPEA2 selection among the not-yet-evaluated ones.

        PlatEMO may pick a design that is already evaluated (the surrogate population
        starts from the real one); spending a real evaluation on it gains nothing, so such
        designs are left out. If none is left, random designs are sent instead.
        """
        if not self.skip_evaluated:  # PlatEMO: any surrogate survivor may be sent
            keep, _ = self._select(plan, P, self.mu)
            return X[keep]
        new = ~self._already_seen(X)
        if not new.any():
            log.warning("%s: every surrogate candidate is already evaluated; sending %d "
                        "random designs", self.name, self.mu)
            return self.rng.uniform(self.problem.xl, self.problem.xu,
                                    size=(self.mu, self.problem.n_var))
        X, P = X[new], P[new]
        keep, _ = self._select(plan, P, self.mu)
        return X[keep]

    def _already_seen(self, X: np.ndarray) -> np.ndarray:
        return already_evaluated(X, self._seen, self.problem.xl, self.problem.xu)

    # ---- tell -------------------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        # Failed designs carry penalty values; they would distort every model, so they
        # stay out of the population and the elite set (they remain in self._seen).
        ok = ~np.asarray(batch.failed, dtype=bool)
        new = _Set(batch.X[ok], batch.F[ok], batch.G[ok])
        if self._pop is None:
            self._pop = new
        else:
            self._pop = self._update_population(new)
        self._elite = self._update_elite(new)
        if len(self._pop) < 2:
            raise AlgorithmStateError(
                f"algorithm {self.name}: only {len(self._pop)} successful evaluation(s) in "
                f"the population; at least 2 are needed to fit surrogates")

    def _update_population(self, new: _Set) -> _Set:
        """Keep the NI - mu best old members (current ranking) and add the new ones."""
        pop = self._pop
        if len(new):
            pop = pop.take(~_rows_in(pop.F, new.F))  # PlatEMO: setdiff on objectives
        pop = pop.take(unique_rows(pop.F))
        n_keep = max(self._ni - len(new), 0)
        if len(pop) > n_keep:
            plan = self._plan
            both = _Set.join(pop, new)
            scaling = ModelPlan("", "", **plan_scaling(
                both.G, self.violation_scaling == "minmax"))
            cv = self._scaled_cv(both, plan.pop_con, scaling)[: len(pop)]
            fit = rank_fitness(plan.pop_mode, pop.F, cv, self.normalise)
            pop = pop.take(environmental_selection(fit, pop.F, n_keep,
                                                   normalise=self.normalise))
        return _Set.join(pop, new)

    @staticmethod
    def _scaled_cv(s: _Set, con: tuple[int, ...], scaling: ModelPlan) -> np.ndarray:
        if not con:
            return np.zeros(len(s))
        return constraint_violation(scaling.scaled(s.G, con))

    def _update_elite(self, new: _Set) -> _Set:
        """Elite set of size N: union, duplicates (objectives) removed, constrained SPEA2."""
        elite = new if self._elite is None else _Set.join(self._elite, new)
        elite = elite.take(unique_rows(elite.F))
        if len(elite) > self.pop_size:
            fit = spea2_fitness(elite.F, constraint_violation(elite.G), normalise=self.normalise)
            elite = elite.take(environmental_selection(fit, elite.F, self.pop_size,
                                                       normalise=self.normalise))
        return elite

    # ---- results ----------------------------------------------------------------------------
    @property
    def elite(self) -> dict[str, np.ndarray]:
        """The elite set of size N (copies): ``X``, ``F``, ``G``."""
        if self._elite is None:
            return {"X": np.zeros((0, 0)), "F": np.zeros((0, 0)), "G": np.zeros((0, 0))}
        return {"X": self._elite.X.copy(), "F": self._elite.F.copy(),
                "G": self._elite.G.copy()}


class MGSAEAIPC(MGSAEA):
    """MGSAEA-IPC: stage one considers the key individual's constraints (seed paper)."""

    name = "mgsaea_ipc"
    stage_one_constraints = "key"

    def __init__(self, *, ungrouped: str = "first", **kwargs) -> None:
        """Args: ``ungrouped`` (see the module docstring) and MGSAEA's keyword arguments."""
        super().__init__(**kwargs)
        if ungrouped not in ("first", "error"):
            raise AlgorithmConfigError(f"algorithm {self.name}: ungrouped must be 'first' "
                                       f"or 'error', got {ungrouped!r}")
        self.ungrouped = ungrouped

    def check_budget(self, problem: ExpensiveProblem, budget: int) -> None:
        # The pre-flight hook that both the CLI (tmopt.run.build) and setup() call: a problem
        # IPC cannot group fails here with one line, before any evaluation.
        super().check_budget(problem, budget)
        self.stage_one_indices(problem)

    def stage_one_indices(self, problem: ExpensiveProblem) -> tuple[int, ...]:
        """The key individual's constraint columns (priority-0 group)."""
        n = int(problem.n_ieq_constr)
        if n == 0:
            return ()
        if declares_groups(problem):
            return tuple(int(i) for i in problem.key_constraint_indices())
        if self.ungrouped == "error" and n > 1:
            raise AlgorithmConfigError(
                f"algorithm {self.name}: problem {problem.name} declares no constraint "
                f"groups, so the key individual's constraints are unknown; declare groups "
                f"(e.g. problem.constraint_groups=split) or set algorithm.ungrouped=first")
        return (0,)


class MGSAEAStar(MGSAEA):
    """MGSAEA*: IPC without the key-individual priority (stage one uses every constraint)."""

    name = "mgsaea_star"
    stage_one_constraints = "all"

    def stage_one_indices(self, problem: ExpensiveProblem) -> tuple[int, ...]:
        return tuple(range(int(problem.n_ieq_constr)))


_FALLBACK_SAID: set[tuple[str, str]] = set()


def _say_fallback_once(algorithm: str, problem: str) -> None:
    """Warn once per process and problem (not on every run of a sweep) what IPC does on
    a problem without constraint groups; every benchmark suite problem is one."""
    level = logging.DEBUG if (algorithm, problem) in _FALLBACK_SAID else logging.WARNING
    _FALLBACK_SAID.add((algorithm, problem))
    log.log(level, "%s: problem %s declares no constraint groups, so its first constraint "
            "(g1) is taken as the key individual's (algorithm.ungrouped=first, the same as "
            "problem.constraint_groups=split; ungrouped=error refuses instead)",
            algorithm, problem)


def declares_groups(problem: ExpensiveProblem) -> bool:
    """True unless the problem only has the default single group "all" of every column."""
    if problem.has_declared_groups:
        return True
    default = (ConstraintGroup("all", tuple(range(int(problem.n_ieq_constr))), 0),)
    return tuple(problem.constraint_groups) != default


def default_surrogate_factory() -> SurrogateFactory:
    """GPSurrogate (BoTorch), the configured default when no factory is passed."""
    try:
        from tmopt.surrogates.gp import GPSurrogate
    except ImportError as exc:  # the GP module is written by another engineer
        raise AlgorithmConfigError(
            "MGSAEA needs a surrogate: pass surrogate=<factory> (tmopt.surrogates.gp is "
            f"not available: {exc})") from exc
    return GPSurrogate


def _rows_in(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Mask of the rows of ``A`` that equal some row of ``B`` exactly."""
    if len(A) == 0 or len(B) == 0:
        return np.zeros(len(A), dtype=bool)
    return (A[:, None, :] == B[None, :, :]).all(axis=2).any(axis=1)
