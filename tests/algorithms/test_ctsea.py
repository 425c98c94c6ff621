"""C-TSEA: AR-MOEA parts against their definitions, the two stages, the archive, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.ctsea import (
    CTSEA,
    adjusted_distance,
    armoea_selection,
    last_front_selection,
    removal_metric,
    uniform_points,
    update_ref_points,
)
from tmopt.algorithms.mgsaea import AlgorithmStateError
from tmopt.problems.suites import PymooBenchmark

from .contract import algorithm_from_yaml, assert_seed_decides_the_archive, run


def igd_ns(dist: np.ndarray) -> float:
    """IGD-NS by its definition (Tian et al., TEVC 2018): distance of every reference point
    to its nearest solution + distance to the nearest reference point of every solution that
    is nearest to no reference point."""
    nearest = np.argmin(dist, axis=0)
    lonely = ~np.isin(np.arange(len(dist)), nearest)
    return dist.min(axis=0).sum() + dist.min(axis=1)[lonely].sum()


def test_uniform_points_count_and_simplex():
    assert uniform_points(100, 2).shape == (100, 2)
    W = uniform_points(100, 3)
    assert W.shape == (91, 3)  # 12 partitions: C(14, 2) = 91 <= 100 < C(15, 2)
    assert np.allclose(W.sum(axis=1), 1.0)


def test_adjusted_distance_moves_reference_point_to_nearest_projection():
    P = np.array([[1.0, 1.0], [2.0, 0.0]])
    # (2, 2) lies on the direction of (1, 1), which is the nearest solution: it moves to (1, 1)
    d = adjusted_distance(P, np.array([[2.0, 2.0]]))
    assert np.allclose(d[:, 0], [0.0, np.sqrt(2.0)])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_removal_metric_is_igd_ns_without_each_solution(seed):
    dist = np.random.default_rng(seed).random((25, 12))
    expected = [igd_ns(np.delete(dist, p, axis=0)) for p in range(25)]
    assert np.allclose(removal_metric(dist), expected)


def test_last_front_selection_deletes_the_smallest_contributors():
    dist = np.random.default_rng(5).random((20, 8))
    keep = last_front_selection(dist, 8)
    assert keep.sum() == 8
    # the first deletion is the solution whose removal leaves the smallest IGD-NS
    first = np.argmin([igd_ns(np.delete(dist, p, axis=0)) for p in range(20)])
    assert not keep[first]


def test_reference_points_and_armoea_selection():
    rng = np.random.default_rng(0)
    F = rng.random((60, 2))
    W = uniform_points(20, 2)
    archive, ref, bounds = update_ref_points(F, W, None)
    assert len(ref) <= len(W) and len(archive) <= 3 * len(W)
    assert np.allclose(bounds[0], F.min(axis=0))
    idx, bounds2 = armoea_selection(F, ref, bounds, 20)
    assert len(idx) == 20 and len(set(idx.tolist())) == 20
    assert np.allclose(bounds2[1], F[idx].max(axis=0))


def test_mw3_budget_2000_two_stages_reach_feasibility():
    alg = CTSEA()
    res = run(alg, PymooBenchmark("mw3"), budget=2000)
    assert len(res.archive) == 2000
    assert alg.stage == 2
    assert res.metrics["feasible_ratio"] > 0.05
    assert res.metrics["igd"] < 1.0


def test_elite_set_holds_no_copies_and_prefers_feasible():
    alg = CTSEA(pop_size=20)
    run(alg, PymooBenchmark("mw3", n_var=6), budget=300)
    assert len(np.unique(alg.elite["X"], axis=0)) == len(alg.elite["X"])
    assert len(alg.pop["X"]) == 20


def test_stage_two_straight_after_the_initial_population_works():
    # 0.5 * 150 < 100 evaluations after the initial population: PlatEMO's archive of the
    # feasible initial designs only could be empty here; ours is filled by violation
    alg = CTSEA()
    res = run(alg, PymooBenchmark("mw3"), budget=300)
    assert alg.stage == 2 and len(res.archive) == 300


def test_same_seed_same_archive():
    assert_seed_decides_the_archive(lambda: CTSEA(pop_size=20), PymooBenchmark("mw3", n_var=6),
                                    budget=200)


@pytest.mark.parametrize("kwargs, text", [
    ({"stage_ratio": 1.5}, "stage_ratio must be in \\[0, 1\\], got 1.5"),
    ({"mutation_eta": 0}, "mutation_eta must be > 0, got 0"),
    ({"pop_size": 1}, "pop_size must be an integer >= 2, got 1"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="ctsea: " + text):
        CTSEA(**kwargs)


def test_budget_below_the_population_is_refused():
    with pytest.raises(AlgorithmConfigError, match="ctsea: budget=50 .* initial sample of 100"):
        run(CTSEA(), PymooBenchmark("mw3"), budget=50)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("ctsea")


def test_reference_platemo_mates_as_platemos_matingselection1():
    # PlatEMO overwrites the IGD-NS fitness with -inf: TournamentSelection then picks the
    # lower index of each pair (its stable sort), i.e. a tournament on equal fitness
    alg = CTSEA(pop_size=20, reference="platemo")
    assert (alg.random_mating, alg.normalise) == (True, False)
    res = run(alg, PymooBenchmark("mw3", n_var=6), budget=60)
    assert len(res.archive) == 60
    from tmopt.algorithms.operators.variation import tournament
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    alg.rng = rng_a
    alg.stage = 1
    np.testing.assert_array_equal(alg._mating_stage_one(),
                                  tournament(np.zeros(len(alg.pop["X"])), 20, rng_b))
    with pytest.raises(AlgorithmConfigError, match="reference must be one of tmopt, "
                                                   "platemo, got 'x'"):
        CTSEA(reference="x")


# ---- reference=platemo: each PlatEMO behaviour alone (docs/algorithms-mgsaea.md) -----------
def test_nbi_weights_are_platemos_uniformpoint_with_its_inner_layer():
    # UniformPoint.m (NBI), N = 100, M = 5: H1 = 4 (C(8,4) = 70 <= 100 < C(9,4)), and as
    # H1 < M an inner layer H2 = 2 (70 + C(6,4) = 85 <= 100 < 70 + C(7,4)) of w/2 + 1/(2M)
    outer = uniform_points(100, 5)
    both = uniform_points(100, 5, inner_layer=True)
    assert (len(outer), len(both)) == (70, 85)
    inner = both[70:]
    assert np.allclose(inner.sum(axis=1), 1.0) and inner.min() >= 0.1 - 1e-12
    assert np.allclose(np.sort((inner - 0.1) * 2 * 2, axis=0),  # back to H2 = 2 partitions
                       np.sort(uniform_points(15, 5) * 2, axis=0))
    assert outer.min() == 0.0 and both.min() == 1e-6  # PlatEMO floors every weight
    assert len(uniform_points(100, 2, inner_layer=True)) == 100  # H1 >= M: one layer
    assert CTSEA(weights="nbi").weights == "nbi"


def test_collapsed_range_upper_bound_one_as_platemo():
    F = np.array([[2.0, 0.0], [2.0, 1.0], [2.0, 0.5]])  # f1 collapsed at 2 > 1
    ref, bounds = uniform_points(2, 2), np.array([[2.0, 0.0], [3.0, 1.0]])
    _, fixed = armoea_selection(F, ref, bounds, 3)
    _, platemo = armoea_selection(F, ref, bounds, 3, collapsed_to_one=True)
    assert fixed[1, 0] == 3.0 and platemo[1, 0] == 1.0  # PlatEMO: upper bound below ideal
    assert fixed[1, 1] == platemo[1, 1] == 1.0


def _sets(X, cv):
    X = np.asarray(X, dtype=float)
    return {"X": X, "F": X.copy(), "G": np.asarray(cv, dtype=float)[:, None]}


def test_archive_copies_reappends_the_feasible_population_as_platemo():
    # UpdateArchive(Archive, [Population, Offspring]) appends every feasible member again
    elite = _sets([[0.1, 0.9]], [0.0])
    pop = _sets([[0.1, 0.9], [0.9, 0.1], [0.5, 0.5]], [0.0, 0.0, 1.0])
    fixed, platemo = CTSEA(pop_size=4), CTSEA(pop_size=4, archive_copies=True)
    kept = fixed._update_elite(elite, pop)["X"]
    copied = platemo._update_elite(elite, pop)["X"]
    assert len(np.unique(kept, axis=0)) == len(kept) == 3  # A, B, then C by violation
    assert len(copied) == 4 and (copied == [0.1, 0.9]).all(axis=1).sum() == 2  # A twice


def test_unfilled_initial_elite_as_platemo_and_its_empty_swap():
    problem = PymooBenchmark("mw3", n_var=6)
    alg = CTSEA(pop_size=20, fill_initial_elite=False)
    res = run(alg, problem, budget=20)
    feasible = (res.archive.G <= 0).all(axis=1).sum()
    assert len(alg.elite["X"]) == feasible < 20  # CTSEA.m: Archive = Population(CV == 0)
    assert len(run(CTSEA(pop_size=20), problem, budget=20).archive) == 20
    filled = CTSEA(pop_size=20)
    run(filled, problem, budget=20)
    assert len(filled.elite["X"]) == 20
    # no feasible initial design and the swap straight after: PlatEMO's population is empty
    alg.elite = {k: v[:0] for k, v in alg.elite.items()}
    with pytest.raises(AlgorithmStateError, match="ctsea: stage two starts with an empty "
                                                  "population"):
        alg._infill()


def test_reference_platemo_sets_every_quirk_and_runs():
    alg = CTSEA(pop_size=20, reference="platemo")
    assert (alg.random_mating, alg.archive_copies, alg.fill_initial_elite,
            alg.collapsed_range, alg.weights, alg.normalise) == (True, True, False, "one",
                                                                  "nbi", False)
    from tmopt.algorithms.ctsea import PLATEMO_SETTINGS
    assert {k: getattr(alg, k) for k in PLATEMO_SETTINGS} == PLATEMO_SETTINGS
    res = run(alg, PymooBenchmark("mw3", n_var=6), budget=200)
    assert len(res.archive) == 200 and alg.stage == 2
    with pytest.raises(AlgorithmConfigError, match="ctsea: weights must be one of "
                                                   "das_dennis, nbi, got 'x'"):
        CTSEA(weights="x")
