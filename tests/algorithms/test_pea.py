"""PEA: constrained probabilistic dominance against its formula and, without uncertainty,
against Pareto dominance and pymoo's sorting; runs, seeds, bad input, config and CLI."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
from scipy.stats import norm

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.operators.constraints import dominance_matrix
from tmopt.algorithms.pea import (
    PEA,
    better_probability,
    cppd_fronts,
    cppd_matrix,
    feasible_probability,
)
from tmopt.evaluation.evaluator import Evaluator
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

from .contract import (
    algorithm_from_yaml,
    assert_seed_decides_the_archive,
    cli_metrics,
    drive_to_budget,
    run,
)
from .test_mgsaea import RBFDouble, TwoGroupProblem


def small(**kw) -> PEA:
    return PEA(**{"pop_size": 12, "wmax": 3, "surrogate": RBFDouble, **kw})


def test_probabilities_follow_the_normal_formulas():
    F = np.array([[0.0, 1.0], [1.0, 1.0]])
    var = np.array([[0.5, 0.0], [0.5, 0.0]])
    P = better_probability(F, var)
    assert P[0, 1, 0] == pytest.approx(norm.cdf(1.0 / np.sqrt(1.0)))
    assert P[1, 0, 0] == pytest.approx(1 - P[0, 1, 0])
    assert P[0, 1, 1] == 0.5  # a tie without uncertainty
    G = np.array([[0.5, -1.0], [-0.2, -0.3]])
    gv = np.array([[0.25, 0.0], [0.04, 0.0]])
    np.testing.assert_allclose(feasible_probability(G, gv),
                               [min(norm.cdf(-0.5 / 0.5), 1.0), norm.cdf(0.2 / 0.2)])
    assert feasible_probability(np.zeros((3, 0)), np.zeros((3, 0))).tolist() == [1, 1, 1]


def test_without_uncertainty_and_constraints_cppd_is_pareto_dominance():
    rng = np.random.default_rng(0)
    F = np.round(rng.random((30, 3)), 1)  # ties on purpose
    zeros, feasible = np.zeros_like(F), -np.ones((30, 2))
    dom = cppd_matrix(F, zeros, feasible, np.zeros((30, 2)))
    np.testing.assert_array_equal(dom, dominance_matrix(F))
    # ... and its fronts are pymoo's non-dominated sorting
    ranks = NonDominatedSorting().do(F, return_rank=True)[1] + 1
    np.testing.assert_array_equal(cppd_fronts(dom, 30), ranks)


def test_an_infeasible_design_dominates_nothing_and_sorting_stops_at_n():
    F = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    G = np.array([[1.0], [-1.0], [-1.0]])  # the best objectives, but infeasible
    dom = cppd_matrix(F, np.zeros_like(F), G, np.zeros_like(G))
    assert not dom[0].any() and dom[1, 2] and not dom[1, 0]
    front = cppd_fronts(dom, 1)
    assert np.isinf(front).sum() == 1  # sorted only as far as 1 row needs: fronts 1, 1


def test_last_front_is_cut_by_farthest_points_after_the_first():
    alg = small()
    F = np.array([[0.0, 0.0], [1.0, 0.1], [1.0, 0.2], [1.0, 0.9]])
    front = np.array([1.0, 2.0, 2.0, 2.0])
    assert alg._select(F, front, 2).tolist() == [0, 3]  # farthest from row 0


def test_runs_on_a_grouped_problem_and_proposes_only_new_designs():
    ev = drive_to_budget(small(), TwoGroupProblem(), 12 + 25)
    X = ev.archive.data.X
    assert len(np.unique(X, axis=0)) == len(X)


def test_mw3_reaches_feasibility():
    res = run(small(pop_size=30), PymooBenchmark("mw3", n_var=6), budget=80)
    assert res.metrics["feasible_ratio"] > 0 and res.metrics["igd"] is not None


@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem = PymooBenchmark(name)
    n = problem.n_var + 2
    drive_to_budget(small(pop_size=n, wmax=2), problem, n + 10)


def test_same_seed_same_archive():
    assert_seed_decides_the_archive(lambda: small(), PymooBenchmark("mw3", n_var=6), 40)


@pytest.mark.parametrize("kwargs, text", [
    ({"wmax": 0}, "wmax must be an integer >= 1, got 0"),
    ({"mu": 0}, "mu must be an integer >= 1, got 0"),
    ({"crossover_eta": -1}, r"crossover_eta must be a finite number in \[0.0, inf\)"),
    ({"surrogate": 3}, "surrogate must be a zero-argument factory"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="pea: " + text):
        PEA(**kwargs)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("pea")


def test_cli_run(tmp_path):
    metrics = cli_metrics(tmp_path, "problem=mw1", "problem.n_var=4", "algorithm=pea",
                          "surrogate=gp", "budget=30", "algorithm.pop_size=10",
                          "algorithm.wmax=2")
    assert metrics["algorithm"] == "pea" and metrics["n_evals"] == 30


# ---- reference=platemo: each PlatEMO behaviour alone (docs/algorithms-frontier.md) ---------
def test_nan_ties_make_a_zero_variance_tie_mutually_non_dominated():
    # rows 0 and 1 tie exactly in f1 (no variance), row 0 is better in f2: Pareto
    # dominance; NDSort_CPPD.m gets 0/0 = NaN in f1, and neither dominates
    F = np.array([[1.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    var = np.zeros_like(F)
    G, gv = np.zeros((3, 0)), np.zeros((3, 0))
    fixed = cppd_matrix(F, var, G, gv)
    platemo = cppd_matrix(F, var, G, gv, nan_ties=True)
    assert fixed[0, 1] and not platemo[0, 1] and not platemo[1, 0]
    assert platemo[0, 2] and platemo[1, 2]  # no tie with row 2: unchanged
    assert np.array_equal(cppd_fronts(platemo, 3), [1, 1, 2])
    assert np.array_equal(cppd_fronts(fixed, 3), [1, 2, 3])
    # with variance the tie is a probability of 1/2 each way in both
    assert np.array_equal(cppd_matrix(F, var + 0.1, G, gv),
                          cppd_matrix(F, var + 0.1, G, gv, nan_ties=True))


def test_no_random_fallback_searches_again_as_platemo(monkeypatch):
    problem = PymooBenchmark("mw3", n_var=6)
    for fallback in (True, False):
        alg = small(random_fallback=fallback)
        alg.setup(problem, budget=100, seed=0)
        ev = Evaluator(problem, 100)
        alg.tell(ev.evaluate(alg.ask()))
        real_search, calls = alg._search, []

        def search(real_search=real_search, calls=calls, alg=alg):
            out = real_search()
            calls.append(1)
            if len(calls) < 3:  # the first two searches find only evaluated designs
                X = alg._X[: len(out[0])]
                return (X, *out[1:])
            return out
        monkeypatch.setattr(alg, "_search", search)
        X = alg.ask()
        if fallback:
            assert len(calls) == 1 and alg.summary()["random_batches"] == 1
        else:  # PEA.m: nothing evaluated, search again from the same models
            assert len(calls) == 3 and alg.summary() == {"random_batches": 0,
                                                         "repeated_searches": 2}
        assert 1 <= len(X) <= alg.mu


def test_reference_platemo_sets_every_deviation_and_runs():
    from tmopt.algorithms.pea import PLATEMO_SETTINGS
    alg = small(reference="platemo")
    assert {k: getattr(alg, k) for k in PLATEMO_SETTINGS} == PLATEMO_SETTINGS
    drive_to_budget(alg, PymooBenchmark("mw3", n_var=6), 12 + 20)
    with pytest.raises(AlgorithmConfigError, match="pea: reference must be one of "
                                                   "tmopt, platemo, got 'x'"):
        PEA(reference="x")
