"""C-TSEA: a simple two-stage evolutionary algorithm for constrained multi-objective problems.

Tags: constrained, multi-objective, not surrogate-assisted (every offspring is evaluated
for real; a Table 3 baseline of the seed paper).

Implements
    F. Ming, W. Gong, H. Zhen, S. Li, L. Wang, Z. Liao, "A simple two-stage evolutionary
    algorithm for constrained multi-objective optimization", Knowledge-Based Systems 228:
    107263, 2021 (reference code: PlatEMO ``Algorithms/Multi-objective optimization/C-TSEA``).

Parameters (keyword arguments; defaults: the constructor's signature):
    pop_size: population and elite-set size N; one generation evaluates N offspring.
    stage_ratio: share of the budget spent in stage one.
    crossover_eta, mutation_eta: SBX (probability 1) and polynomial mutation
        (1/n_var per variable), PlatEMO's ``OperatorGA`` defaults.
    normalise: SPEA2 density and truncation on min-max normalised objectives
        (False = PlatEMO's raw distances); see tmopt.algorithms.operators.survival.

Algorithm:
    Stage one (the first ``stage_ratio`` of the budget) ignores the constraints and drives
    the population towards the unconstrained front with AR-MOEA (Tian et al., IEEE TEVC
    22(4), 2018: IGD-NS based mating and environmental selection with adaptive reference
    points), while an elite set of size N (the paper's "archive"; tmopt's archive is every
    real evaluation) collects the feasible designs (filled up with the least-violating
    ones, cut back by constrained SPEA2). Stage two swaps elite set and
    population once and evolves the population with SPEA2 under constrained dominance
    (binary tournament on its fitness, SBX + PM, SPEA2 environmental selection).

Quirks of the reference fixed here (docs/algorithms-mgsaea.md, "C-TSEA"):
    * ``MatingSelection1`` computes the IGD-NS fitness and then overwrites every entry
      with -inf (AR-MOEA's line that copies it back was dropped), so stage one mates at
      random; here the IGD-NS fitness drives the tournament, as in AR-MOEA.
    * ``UpdateArchive`` re-appends the feasible members of the current population every
      generation, so the elite set fills with copies; here only designs not yet in it
      are added.
    * The elite set starts with the feasible initial designs only and may be empty when
      stage two begins (then the swapped population is empty); here it is filled to N
      with the least-violating initial designs, as every later update does.
    * A collapsed objective range sets the upper bound to 1 (meaningless when the ideal
      value exceeds 1); here it becomes ideal + 1.
    * AR-MOEA's ``UniformPoint`` adds an inner layer for many objectives; here one
      Das-Dennis layer (pymoo) with at most N points is used.
Each quirk is a constructor argument (defaults: the fixes; docs/algorithms-mgsaea.md,
"PlatEMO's behaviour as a setting"): ``random_mating=True`` (quirk 1),
``archive_copies=True`` (2), ``fill_initial_elite=False`` (3), ``collapsed_range="one"``
(4), ``weights="nbi"`` (5: PlatEMO's ``UniformPoint``, two layers and the 1e-6 floor);
``normalise=False`` gives PlatEMO's raw SPEA2 distances. ``reference="platemo"`` sets all
six (:data:`PLATEMO_SETTINGS`).
"""

from __future__ import annotations

import numpy as np
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
from pymoo.util.ref_dirs import get_reference_directions
from scipy.spatial.distance import cdist

from tmopt.algorithms.base import Algorithm, AlgorithmConfigError, check_choice
from tmopt.algorithms.mgsaea import AlgorithmStateError
from tmopt.algorithms.operators.survival import environmental_selection, spea2_fitness
from tmopt.algorithms.operators.variation import ga_offspring, tournament
from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.metrics.indicators import constraint_violation

#: ``reference``: "tmopt" (the fixes in the module docstring) or "platemo" (C-TSEA.m's
#: behaviour for each of them, :data:`PLATEMO_SETTINGS`).
REFERENCES = ("tmopt", "platemo")
#: What ``reference="platemo"`` sets (each can also be set alone to measure one fix).
PLATEMO_SETTINGS = {"random_mating": True, "archive_copies": True, "fill_initial_elite": False,
                    "collapsed_range": "one", "weights": "nbi", "normalise": False}
#: Upper bound of the normalisation where an objective's range collapses (< 1e-6):
#: "ideal_plus_one" (the fix) or "one" (AR-MOEA's and C-TSEA's ``Range(2, ...) = 1``).
COLLAPSED_RANGES = ("ideal_plus_one", "one")
#: Reference weights: "das_dennis" (one layer, pymoo) or "nbi" (PlatEMO's
#: ``UniformPoint``: an inner layer when the outer one has fewer than M partitions,
#: every weight floored at 1e-6).
WEIGHTS = ("das_dennis", "nbi")


# ---- AR-MOEA parts (no library offers them) --------------------------------------------------
def uniform_points(n: int, m: int, inner_layer: bool = False) -> np.ndarray:
    """Das-Dennis weights on the unit simplex: the most partitions H1 with at most ``n``
    points. ``inner_layer``: PlatEMO's ``UniformPoint`` (NBI), which for H1 < m adds a
    second layer of H2 partitions (the most that keep the total <= ``n``) shrunk to
    w / 2 + 1 / (2m) and floors every weight at 1e-6 (Das & Dennis, SIAM J. Optim. 8(3),
    1998; the two layers: Deb & Jain, IEEE TEVC 18(4), 2014, Sec. V)."""
    if m == 1:
        return np.ones((1, 1))
    h = 1
    while _n_simplex_points(h + 1, m) <= n:
        h += 1
    W = get_reference_directions("das-dennis", m, n_partitions=h)
    if not inner_layer:
        return W
    if h < m:
        h2 = 0
        while _n_simplex_points(h, m) + _n_simplex_points(h2 + 1, m) <= n:
            h2 += 1
        if h2 > 0:
            inner = get_reference_directions("das-dennis", m, n_partitions=h2)
            W = np.vstack([W, inner / 2.0 + 1.0 / (2.0 * m)])
    return np.maximum(W, 1e-6)


def _n_simplex_points(h: int, m: int) -> int:
    from math import comb

    return comb(h + m - 1, m - 1)


def _cosine_similarity(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    return np.nan_to_num(1.0 - cdist(A, B, metric="cosine"), nan=0.0)


def adjusted_distance(P: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Distance of each (translated) solution to each reference point moved onto the front.

    AR-MOEA: every reference point is scaled along its direction to the projection length
    of the solution nearest to that direction (smallest perpendicular distance).
    """
    P = np.maximum(P, 1e-6)
    R = np.maximum(R, 1e-6)
    cos = np.clip(_cosine_similarity(P, R), -1.0, 1.0)
    norm_p = np.linalg.norm(P, axis=1)[:, None]
    d1 = norm_p * cos
    d2 = norm_p * np.sqrt(1.0 - cos**2)
    nearest = np.argmin(d2, axis=0)
    length = d1[nearest, np.arange(len(R))] / np.linalg.norm(R, axis=1)
    return cdist(P, R * length[:, None])


def _grow_by_cosine(sim: np.ndarray, chosen: np.ndarray, target: int) -> np.ndarray:
    """Add, one at a time, the candidate least similar to everything chosen so far."""
    chosen = chosen.copy()
    closest = sim[:, chosen].max(axis=1) if chosen.any() else np.full(len(sim), -np.inf)
    while chosen.sum() < target:
        cand = np.flatnonzero(~chosen)
        pick = cand[np.argmin(closest[cand])]
        chosen[pick] = True
        closest = np.maximum(closest, sim[:, pick])
    return chosen


def update_ref_points(
    archive: np.ndarray, W: np.ndarray, bounds: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """AR-MOEA's reference-point adaptation; returns ``(archive, ref_points, bounds)``.

    ``bounds`` holds the ideal point (row 0) and the upper bound of the normalisation
    (row 1). The archive keeps the non-dominated objective vectors that contribute to some
    weight vector plus the most dissimilar others (at most 3|W|); the reference points are
    the valid weight vectors plus the most dissimilar archive members (|W| in all).
    """
    front = NonDominatedSorting().do(archive, only_non_dominated_front=True)
    A = np.unique(archive[front], axis=0)
    if bounds is not None:
        bounds = bounds.copy()
        bounds[0] = np.minimum(bounds[0], A.min(axis=0))
    else:
        bounds = np.vstack([A.min(axis=0), A.max(axis=0)])
    if len(A) <= 1:
        return A, W, bounds
    tA = A - bounds[0]
    Ws = W * (bounds[1] - bounds[0])
    dist = adjusted_distance(tA, Ws)
    contributing = np.unique(np.argmin(dist, axis=0))
    valid_w = np.unique(np.argmin(dist, axis=1)[contributing])
    keep = np.isin(np.arange(len(A)), contributing)
    keep = _grow_by_cosine(_cosine_similarity(tA, tA), keep, min(3 * len(W), len(A)))
    A, tA = A[keep], tA[keep]
    ref = np.vstack([Ws[valid_w], tA])
    chosen = np.arange(len(ref)) < len(valid_w)
    chosen = _grow_by_cosine(_cosine_similarity(ref, ref), chosen, min(len(W), len(ref)))
    return A, ref[chosen], bounds


def removal_metric(dist: np.ndarray) -> np.ndarray:
    """IGD-NS of the set after removing each solution (larger = the solution matters more).

    ``dist`` is (solutions, reference points). IGD-NS = sum over reference points of the
    distance to the nearest solution + sum over non-contributing solutions (nearest to no
    reference point) of their distance to the nearest reference point.
    """
    n, nr = dist.shape
    conv = dist.min(axis=1)
    order = np.argsort(dist, axis=0, kind="stable")
    r1 = order[0]
    d1 = dist[r1, np.arange(nr)]
    contributing = np.zeros(n, dtype=bool)
    contributing[r1] = True
    total = d1.sum() + conv[~contributing].sum()
    metric = total - conv
    if n < 2:
        return metric
    r2 = order[1]
    d2 = dist[r2, np.arange(nr)]
    gain = np.bincount(r1, weights=d2 - d1, minlength=n)
    # the second-nearest solutions that start contributing, each counted once per owner
    pairs = np.unique(np.column_stack([r1, r2])[~contributing[r2]], axis=0)
    newly = np.bincount(pairs[:, 0], weights=conv[pairs[:, 1]], minlength=n) \
        if len(pairs) else np.zeros(n)
    metric[contributing] = (total + gain - newly)[contributing]
    return metric


def last_front_selection(dist: np.ndarray, k: int) -> np.ndarray:
    """Mask of the ``k`` solutions kept by deleting the least IGD-NS contributor repeatedly."""
    remain = np.ones(len(dist), dtype=bool)
    while remain.sum() > k:
        idx = np.flatnonzero(remain)
        remain[idx[np.argmin(removal_metric(dist[idx]))]] = False
    return remain


def armoea_selection(F: np.ndarray, ref: np.ndarray, bounds: np.ndarray, n: int,
                     collapsed_to_one: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """AR-MOEA's environmental selection on objectives only; returns ``(indices, bounds)``.
    A collapsed range (< 1e-6) gets the upper bound ideal + 1 or, ``collapsed_to_one``,
    1 (PlatEMO)."""
    fronts = NonDominatedSorting().do(F, n_stop_if_ranked=n)
    keep = np.concatenate(fronts[:-1]).astype(int) if len(fronts) > 1 else np.zeros(0, int)
    last = np.asarray(fronts[-1], dtype=int)
    if len(keep) + len(last) > n:
        dist = adjusted_distance(F[last] - bounds[0], ref)
        last = last[last_front_selection(dist, n - len(keep))]
    idx = np.sort(np.concatenate([keep, last]))
    bounds = bounds.copy()
    bounds[1] = F[idx].max(axis=0)
    flat = bounds[1] - bounds[0] < 1e-6
    bounds[1, flat] = 1.0 if collapsed_to_one else bounds[0, flat] + 1.0
    return idx, bounds


# ---- the algorithm ----------------------------------------------------------------------------
class CTSEA(Algorithm):
    """C-TSEA (see the module docstring for parameters and the algorithm)."""

    name = "ctsea"

    def __init__(self, *, pop_size: int = 100, stage_ratio: float = 0.5,
                 crossover_eta: float = 20.0, mutation_eta: float = 20.0,
                 normalise: bool = True, random_mating: bool = False,
                 archive_copies: bool = False, fill_initial_elite: bool = True,
                 collapsed_range: str = "ideal_plus_one", weights: str = "das_dennis",
                 reference: str = "tmopt") -> None:
        super().__init__(pop_size=pop_size)
        self.reference = check_choice(self.name, "reference", reference, REFERENCES)
        check_choice(self.name, "collapsed_range", collapsed_range, COLLAPSED_RANGES)
        check_choice(self.name, "weights", weights, WEIGHTS)
        if reference == "platemo":  # every documented fix undone (PLATEMO_SETTINGS)
            random_mating, normalise = True, False
            archive_copies, fill_initial_elite = True, False
            collapsed_range, weights = "one", "nbi"
        self.random_mating = bool(random_mating)
        self.archive_copies = bool(archive_copies)
        self.fill_initial_elite = bool(fill_initial_elite)
        self.collapsed_range = collapsed_range
        self.weights = weights
        if isinstance(stage_ratio, bool) or not isinstance(stage_ratio, (int, float)) \
                or not 0.0 <= stage_ratio <= 1.0:
            raise AlgorithmConfigError(f"algorithm {self.name}: stage_ratio must be in "
                                       f"[0, 1], got {stage_ratio!r}")
        for label, eta in (("crossover_eta", crossover_eta), ("mutation_eta", mutation_eta)):
            if isinstance(eta, bool) or not isinstance(eta, (int, float)) or not eta > 0:
                raise AlgorithmConfigError(f"algorithm {self.name}: {label} must be > 0, "
                                           f"got {eta!r}")
        self.stage_ratio = float(stage_ratio)
        self.crossover_eta = float(crossover_eta)
        self.mutation_eta = float(mutation_eta)
        self.normalise = bool(normalise)

    def _setup(self) -> None:
        self.W = uniform_points(self.pop_size, self.problem.n_obj,
                                inner_layer=self.weights == "nbi")
        self.stage = 1
        self.pop: dict | None = None
        self.elite: dict | None = None
        self._pending_stage = 1

    def info(self) -> dict:
        return {"stage": self.stage}

    # ---- ask ------------------------------------------------------------------------------
    def _infill(self) -> np.ndarray:
        if self.pop is None:
            return FloatRandomSampling().do(self.problem, self.pop_size,
                                            random_state=self.rng).get("X")
        if self.stage == 1 and self.n_evals >= self.stage_ratio * self.budget:
            self.pop, self.elite = self.elite, self.pop  # swap once
            self.stage = 2
            if len(self.pop["X"]) == 0:  # only with fill_initial_elite=False (quirk 3)
                raise AlgorithmStateError(
                    f"algorithm {self.name}: stage two starts with an empty population (no "
                    f"feasible initial design, fill_initial_elite=False, budget <= "
                    f"{self.pop_size}/stage_ratio); PlatEMO's C-TSEA fails here too")
        self._pending_stage = self.stage
        mates = self._mating_stage_one() if self.stage == 1 else self._mating_stage_two()
        return self._variation(self.pop["X"][mates])

    def _mating_stage_one(self) -> np.ndarray:
        if self.random_mating:  # PlatEMO's MatingSelection1: every fitness -inf
            return tournament(np.zeros(len(self.pop["X"])), self.pop_size, self.rng)
        dist = adjusted_distance(self.pop["F"] - self.bounds[0], self.ref)
        return tournament(-removal_metric(dist), self.pop_size, self.rng)

    def _mating_stage_two(self) -> np.ndarray:
        fit = spea2_fitness(self.pop["F"], constraint_violation(self.pop["G"]),
                            normalise=self.normalise)
        return tournament(fit, self.pop_size, self.rng)

    def _variation(self, parents: np.ndarray) -> np.ndarray:
        n_pairs = max(len(parents) // 2, 1)
        pairs = np.arange(2 * n_pairs).reshape(2, n_pairs).T  # PlatEMO: first half x second
        return ga_offspring(parents, pairs, self.problem.xl, self.problem.xu, self.rng,
                            crossover_eta=self.crossover_eta, mutation_eta=self.mutation_eta)

    # ---- tell -----------------------------------------------------------------------------
    def _advance(self, batch: EvaluatedBatch) -> None:
        new = {"X": batch.X, "F": batch.F, "G": batch.G}
        if self.pop is None:
            self.pop = new
            self.ref_archive, self.ref, self.bounds = update_ref_points(new["F"], self.W, None)
            self.elite = self._update_elite(None, new) if self.fill_initial_elite \
                else _take(new, np.flatnonzero(constraint_violation(new["G"]) <= 0.0))
        elif self._pending_stage == 1:
            both = _join(self.pop, new)
            self.ref_archive, self.ref, self.bounds = update_ref_points(
                np.vstack([self.ref_archive, new["F"]]), self.W, self.bounds)
            self.elite = self._update_elite(self.elite, both)
            idx, self.bounds = armoea_selection(both["F"], self.ref, self.bounds, self.pop_size,
                                                self.collapsed_range == "one")
            self.pop = _take(both, idx)
        else:
            both = _join(self.pop, new)
            fit = spea2_fitness(both["F"], constraint_violation(both["G"]),
                                normalise=self.normalise)
            idx = environmental_selection(fit, both["F"], self.pop_size, normalise=self.normalise)
            self.pop = _take(both, idx[np.argsort(fit[idx], kind="stable")])

    def _update_elite(self, elite: dict | None, pop: dict) -> dict:
        """Feasible designs join (no copies, unless ``archive_copies``: PlatEMO appends every
        feasible member of [population, offspring] each generation); fill to N by violation
        or cut by CDP-SPEA2."""
        cv = constraint_violation(pop["G"])
        fresh = cv <= 0.0
        if elite is not None and not self.archive_copies:
            fresh &= ~_rows_in(pop["X"], elite["X"])
        arc = _take(pop, np.flatnonzero(fresh)) if elite is None \
            else _join(elite, _take(pop, np.flatnonzero(fresh)))
        n = self.pop_size
        if len(arc["X"]) < n:
            rest = np.flatnonzero(~_rows_in(pop["X"], arc["X"]))
            rest = rest[np.argsort(cv[rest], kind="stable")][: n - len(arc["X"])]
            arc = _join(arc, _take(pop, rest))
        elif len(arc["X"]) > n:
            fit = spea2_fitness(arc["F"], constraint_violation(arc["G"]), normalise=self.normalise)
            arc = _take(arc, environmental_selection(fit, arc["F"], n, normalise=self.normalise))
        return arc


def _take(s: dict, idx) -> dict:
    return {k: v[idx] for k, v in s.items()}


def _join(a: dict, b: dict) -> dict:
    return {k: np.vstack([a[k], b[k]]) for k in a}


def _rows_in(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    if len(A) == 0 or len(B) == 0:
        return np.zeros(len(A), dtype=bool)
    return (A[:, None, :] == B[None, :, :]).all(axis=2).any(axis=1)
