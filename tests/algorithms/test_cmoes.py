"""CMOES: promising region, even search and CDP selection by hand, the stages, runs, seeds."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.core.evaluator import Evaluator as PymooEvaluator
from pymoo.core.population import Population
from pymoo.core.problem import Problem
from pymoo.operators.survival.rank_and_crowding import RankAndCrowding
from pymoo.problems.static import StaticProblem

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.cmoes import CMOES, _Set, even_search, promising
from tmopt.algorithms.operators.survival import lexicographic_rank, nsga2_selection
from tmopt.algorithms.operators.variation import de_offspring
from tmopt.evaluation.evaluator import Evaluator
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

from .contract import (
    algorithm_from_yaml,
    assert_seed_decides_the_archive,
    cli_metrics,
    drive_to_budget,
    run,
)


def test_promising_region_is_what_no_feasible_solution_dominates():
    feasible = np.array([[0.2, 0.8], [0.6, 0.3]])
    F = np.array([[0.1, 0.9],    # better in f1 than both: promising
                  [0.3, 0.9],    # dominated by (0.2, 0.8)
                  [0.6, 0.3],    # equal to a feasible solution: promising (GetLable.m)
                  [0.7, 0.4],    # dominated by (0.6, 0.3)
                  [0.4, 0.5]])   # incomparable with both
    assert promising(F, feasible).tolist() == [True, False, True, False, True]
    assert promising(F, np.zeros((0, 2))).all()  # no feasible solution: everything


def test_even_search_splits_the_region_into_front_and_relaxed_feasible():
    F = np.array([[0.0, 1.0], [0.5, 0.5], [1.0, 0.0], [0.6, 0.6], [0.9, 0.9], [2.0, 2.0]])
    G = np.array([[3.0], [0.0], [1.0], [0.5], [0.2], [0.0]])
    pop = _Set(np.arange(6.0)[:, None], F, G)
    feasible = np.array([[1.5, 1.5]])  # dominates only the last row
    p2, fit2, p3, cv3 = even_search(pop, feasible, n=10, tau=0.5, max_cv=3.0, normalise=True)
    assert p2.X[:, 0].tolist() == [0.0, 1.0, 2.0] and np.all(fit2 < 1.0)  # non-dominated
    # eps = 3 * (1 - 0.5)^2 = 0.75: rows with CV <= 0.75 inside the promising region
    assert p3.X[:, 0].tolist() == [1.0, 3.0, 4.0] and cv3.tolist() == [0.0, 0.5, 0.2]
    p2, _, p3, _ = even_search(pop, feasible, n=2, tau=0.5, max_cv=3.0, normalise=True)
    assert len(p2) == 2 and len(p3) == 2  # SPEA2 truncation to N


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nsga2_selection_equals_pymoo_rank_and_crowding(seed):
    rng = np.random.default_rng(seed)
    F = rng.random((40, 2))
    G = np.where(rng.random((40, 1)) < 0.5, -rng.random((40, 1)), rng.random((40, 1)))
    pop = Population.new("X", np.zeros((40, 1)))
    problem = Problem(n_var=1, n_obj=2, n_ieq_constr=1, xl=0.0, xu=1.0)
    PymooEvaluator().eval(StaticProblem(problem, F=F, G=G), pop)
    theirs = RankAndCrowding().do(problem, pop, n_survive=25, random_state=rng)
    ours = nsga2_selection(F, np.maximum(G[:, 0], 0.0), 25)[0]
    key = {tuple(f) for f in theirs.get("F")}
    assert key == {tuple(f) for f in F[ours]}


def test_lexicographic_rank_orders_front_then_crowding():
    front = np.array([1, 0, 0, 1])
    crowd = np.array([np.inf, 0.3, np.inf, 0.1])
    assert lexicographic_rank(front, -crowd).tolist() == [2.0, 1.0, 0.0, 3.0]


def test_de_offspring_is_the_de_formula_inside_the_bounds():
    problem = PymooBenchmark("mw3", n_var=4)
    rng = np.random.default_rng(0)
    base, r1, r2 = (rng.random((50, 4)) for _ in range(3))
    kids = de_offspring(base, r1, r2, problem, np.random.default_rng(1), mutation_eta=1e9)
    # eta -> inf makes the polynomial mutation vanish; CR = 1 takes the whole donor
    assert np.allclose(kids, np.clip(base + 0.5 * (r1 - r2), 0.0, 1.0), atol=1e-6)


def test_stage_one_then_even_search_with_three_populations():
    problem = PymooBenchmark("mw3", n_var=6)
    alg = CMOES(pop_size=20)
    alg.setup(problem, budget=1200, seed=0)
    ev = Evaluator(problem, 1200)
    asked = []
    while ev.remaining:
        X = alg.ask()
        asked.append((alg.stage, len(X), len(alg.p1) if alg.p1 else 0,
                      len(alg.p2) if alg.p2 else 0, len(alg.p3) if alg.p3 else 0))
        alg.tell(ev.evaluate(X[: ev.remaining]))
    assert asked[0][:2] == (1, 40)                      # 2N initial designs
    assert asked[1][:2] == (1, 60)                      # stage one: 2N + N offspring
    stage_two = [a for a in asked if a[0] == 2]
    assert stage_two, "the even search never started"
    for _, n_asked, n1, n2, n3 in stage_two[1:-1]:
        assert n_asked == n1 + n2 + n3 and n1 == 20 and n2 <= 20 and n3 <= 20
    assert np.any(alg.p1.cv == 0.0)


@pytest.mark.parametrize("operator", ["ga", "de"])
def test_mw3_reaches_the_feasible_front(operator):
    alg = CMOES(pop_size=30, operator=operator)
    res = run(alg, PymooBenchmark("mw3", n_var=6), budget=2000)
    assert len(res.archive) == 2000 and alg.stage == 2
    # seeds 0-2: feasible shares 0.46-0.50 (ga) / 0.29-0.34 (de), IGD 0.011-0.018
    assert res.metrics["feasible_ratio"] > 0.2
    assert res.metrics["igd"] < 0.05


@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem, alg = PymooBenchmark(name), CMOES(pop_size=6, stage_ratio=0.0)
    drive_to_budget(alg, problem, alg.initial_sample_size(problem) + 60)


def test_same_seed_same_archive():
    for operator in ("ga", "de"):
        assert_seed_decides_the_archive(lambda op=operator: CMOES(pop_size=10, operator=op),
                                        PymooBenchmark("mw3", n_var=6), budget=300)


@pytest.mark.parametrize("kwargs, text", [
    ({"pop_size": 1}, "pop_size must be an integer >= 2, got 1"),
    ({"operator": "pso"}, "operator must be one of ga, de, got 'pso'"),
    ({"stage_ratio": 2}, r"stage_ratio must be a finite number in \[0.0, 1.0\], got 2"),
    ({"mutation_eta": -1}, r"mutation_eta must be a finite number in \[0.0, inf\), got -1"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="cmoes: " + text):
        CMOES(**kwargs)


def test_budget_below_the_two_initial_populations_is_refused():
    with pytest.raises(AlgorithmConfigError, match="cmoes: budget=150 .* initial sample of 200"):
        run(CMOES(), PymooBenchmark("mw3"), budget=150)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("cmoes")


def test_cli_run(tmp_path):
    metrics = cli_metrics(tmp_path, "problem=mw1", "algorithm=cmoes", "budget=100",
                          "algorithm.pop_size=10", "algorithm.operator=de")
    assert metrics["algorithm"] == "cmoes" and metrics["n_evals"] == 100


# ---- reference=platemo: each PlatEMO behaviour alone (docs/algorithms-baselines.md) --------
def _at_the_switch(**kwargs) -> CMOES:
    """A CMOES in stage one on MW3 (budget 2000: 20 stage-one generations) once P1 holds a
    feasible design."""
    problem = PymooBenchmark("mw3", n_var=6)
    alg = CMOES(pop_size=20, **kwargs)
    alg.setup(problem, budget=2000, seed=3)
    ev = Evaluator(problem, 2000)
    alg.tell(ev.evaluate(alg.ask()))
    while not np.any(alg.p1.cv == 0.0):
        alg.tell(ev.evaluate(alg.ask()))
    assert alg.stage == 1
    alg._tau = 0.2
    return alg


def test_switch_keeps_populations_reads_the_even_searchs_fitness_as_platemo():
    fixed, platemo = _at_the_switch(), _at_the_switch(switch_keeps_populations=True)
    assert np.array_equal(fixed.p2.X, platemo.p2.X)  # the same state before the switch
    p2_before, p3_before, p1 = platemo.p2, platemo.p3, platemo.p1
    fixed._switch_stage()
    platemo._switch_stage()
    union = _Set.join(p1, p2_before, p3_before)
    p2, fit2, p3, fit3 = even_search(union, p1.F[p1.cv == 0.0], 20, 0.2,
                                     float(union.cv.max()), True)
    # tmopt: P2/P3 with their own fitness; CMOES.m: the old P2/P3 with the new fitness
    assert np.array_equal(fixed.p2.X, p2.X) and np.array_equal(fixed._fit2, fit2)
    assert platemo.p2 is p2_before and platemo.p3 is p3_before
    assert np.array_equal(platemo._fit2, fit2) and np.array_equal(platemo._fit3, fit3)
    from tmopt.algorithms.operators.survival import spea2_fitness
    # the fitness is another population's: not P2's own (tournaments read it by position)
    assert len(platemo._fit2) <= len(platemo.p2)
    assert not np.array_equal(platemo._fit2, spea2_fitness(p2_before.F)[: len(fit2)])
    own = spea2_fitness(p1.F, p1.cv)
    assert np.array_equal(fixed._fit1, own)
    assert np.array_equal(platemo._fit1, np.sort(own)) and not np.array_equal(own, np.sort(own))


def test_stale_feasible_mask_bounds_the_region_by_the_old_p1s_places(monkeypatch):
    import tmopt.algorithms.cmoes as cmoes

    seen = []
    real = cmoes.even_search
    monkeypatch.setattr(cmoes, "even_search",
                        lambda pop, F_feasible, *a: seen.append(F_feasible) or real(
                            pop, F_feasible, *a))
    for stale in (False, True):
        alg = _at_the_switch(stale_feasible_mask=stale)
        alg._switch_stage()
        old_mask = alg.p1.cv == 0.0
        problem = alg.problem
        off_X = alg._stage_two_offspring()
        F, G = problem.evaluate(off_X)
        alg._stage_two_selection(_Set(off_X, F, G))
        new_p1 = alg.p1
        expected = new_p1.F[old_mask] if stale else new_p1.F[new_p1.cv == 0.0]
        assert np.array_equal(seen[-1], expected)
    # the masks differ on this run: PlatEMO's region is bounded by other designs
    assert not np.array_equal(old_mask, new_p1.cv == 0.0)


def test_reference_platemo_sets_both_and_raw_distances_and_runs():
    from tmopt.algorithms.cmoes import PLATEMO_SETTINGS
    alg = CMOES(pop_size=20, reference="platemo")
    assert {k: getattr(alg, k) for k in PLATEMO_SETTINGS} == PLATEMO_SETTINGS
    drive_to_budget(alg, PymooBenchmark("mw3", n_var=6), budget=600)
    assert alg.stage == 2
    with pytest.raises(AlgorithmConfigError, match="cmoes: reference must be one of "
                                                   "tmopt, platemo, got 'x'"):
        CMOES(reference="x")
