"""C-MOEA/D: the constrained replacement rule by hand, defaults, runs, seeds, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.core.population import Population

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.cmoead import CMOEAD, ConstrainedMOEAD
from tmopt.evaluation.evaluator import Evaluator
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

from .contract import (
    algorithm_from_yaml,
    assert_seed_decides_the_archive,
    cli_metrics,
    drive_to_budget,
    run,
)


def moead_with(F, CV, max_replacements=4):
    """A ConstrainedMOEAD over 4 weight vectors whose population has the given values."""
    W = np.array([[1.0, 0.0], [2 / 3, 1 / 3], [1 / 3, 2 / 3], [0.0, 1.0]])
    alg = ConstrainedMOEAD(W, n_neighbors=4, max_replacements=max_replacements, theta=5.0,
                           batch_size=1, prob_neighbor_mating=0.9)
    alg.pop = Population.new("X", np.zeros((4, 1)), "F", np.asarray(F, float),
                             "CV", np.asarray(CV, float).reshape(-1, 1))
    alg.ideal = np.zeros(2)
    return alg


def child(f, cv):
    return Population.new("X", np.ones((1, 1)), "F", np.array([f], float),
                          "CV", np.array([[cv]], float))[0]


def pbi(f, w, theta=5.0):
    """g^pbi(f | w, z=0) = d1 + theta * d2 (Zhang & Li 2007), written out."""
    w = np.asarray(w, float) / np.linalg.norm(w)
    d1 = float(np.dot(f, w))
    return d1 + theta * float(np.linalg.norm(np.asarray(f, float) - d1 * w))


def test_smaller_violation_wins_whatever_the_objectives():
    alg = moead_with(F=[[0.1, 0.1]] * 4, CV=[0.0, 2.0, 0.5, 3.0])
    alg._replace_constrained(np.arange(4), child([5.0, 5.0], cv=1.0))
    replaced = [bool(np.all(alg.pop[i].F == 5.0)) for i in range(4)]
    assert replaced == [False, True, False, True]  # only where the old CV is larger


def test_equal_violation_compares_pbi_ties_replace():
    F = np.array([[0.6, 0.0], [0.3, 0.3], [0.1, 0.5], [0.0, 0.2]])
    new = np.array([0.5, 0.0])
    alg = moead_with(F=F, CV=[0.0] * 4)
    alg._replace_constrained(np.arange(4), child(new, cv=0.0))
    expected = [pbi(new, w) <= pbi(f, w) for f, w in zip(F, alg.ref_dirs, strict=True)]
    replaced = [bool(np.all(alg.pop[i].F == new)) for i in range(4)]
    assert replaced == expected
    assert expected == [True, False, False, False]  # the rule is not vacuous here
    tie = moead_with(F=[[0.5, 0.0]] * 4, CV=[0.3] * 4)
    tie._replace_constrained(np.array([0]), child([0.5, 0.0], cv=0.3))
    assert np.array_equal(tie.pop[0].X, [1.0])  # an equally good child replaces (CMOEAD.m)


def test_at_most_nr_replacements_in_pool_order():
    alg = moead_with(F=[[1.0, 1.0]] * 4, CV=[1.0] * 4, max_replacements=2)
    alg._replace_constrained(np.array([3, 1, 0, 2]), child([0.0, 0.0], cv=0.0))
    replaced = [bool(np.all(alg.pop[i].F == 0.0)) for i in range(4)]
    assert replaced == [False, True, False, True]  # the first two of the pool


def test_defaults_follow_platemo():
    alg = CMOEAD()
    alg.setup(PymooBenchmark("mw3"), budget=300, seed=0)
    inner = alg._algorithm
    assert inner.pop_size == 100 and inner.n_neighbors == 10 and inner.max_replacements == 1
    assert inner.prob_neighbor_mating == 0.9 and inner.decomposition.theta == 5.0
    neighbours = inner.neighbors[0]
    assert neighbours[0] == 0 and set(neighbours) == set(range(10))  # nearest weights
    three = CMOEAD()
    assert three.initial_sample_size(PymooBenchmark("mw4")) == 91  # C(14, 2) weights for M=3


def test_steady_state_one_child_per_ask_and_every_evaluation_counted():
    problem = PymooBenchmark("mw3", n_var=6)
    alg = CMOEAD(pop_size=20)
    alg.setup(problem, budget=60, seed=0)
    ev = Evaluator(problem, 60)
    sizes = []
    while ev.remaining:
        X = alg.ask()
        sizes.append(len(X))
        alg.tell(ev.evaluate(X[: ev.remaining]))
    assert sizes[0] == 20 and set(sizes[1:]) == {1}
    assert alg.n_evals == 60 and len(ev.archive) == 60


def test_batches_are_applied_in_order():
    res = run(CMOEAD(pop_size=20, batch_size=7), PymooBenchmark("mw3", n_var=6), budget=60)
    assert len(res.archive) == 60
    assert np.bincount(res.archive.batch).tolist() == [20, 7, 7, 7, 7, 7, 5]


def test_mw3_reaches_the_feasible_front():
    res = run(CMOEAD(pop_size=50), PymooBenchmark("mw3", n_var=6), budget=2000)
    assert len(res.archive) == 2000
    # seeds 0-2 give feasible shares 0.54-0.63 and IGD 0.032-0.043
    assert res.metrics["feasible_ratio"] > 0.4
    assert res.metrics["igd"] < 0.1


@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem, alg = PymooBenchmark(name), CMOEAD(pop_size=10)
    drive_to_budget(alg, problem, alg.initial_sample_size(problem) + 15)


def test_same_seed_same_archive():
    assert_seed_decides_the_archive(lambda: CMOEAD(pop_size=20),
                                    PymooBenchmark("mw3", n_var=6), budget=80)


@pytest.mark.parametrize("kwargs, text", [
    ({"pop_size": 1}, "pop_size must be an integer >= 2, got 1"),
    ({"n_neighbors": 1}, "n_neighbors must be an integer >= 2, got 1"),
    ({"max_replacements": 0}, "max_replacements must be an integer >= 1, got 0"),
    ({"prob_neighbor_mating": 1.5}, r"prob_neighbor_mating must be a finite number in "
                                    r"\[0.0, 1.0\], got 1.5"),
    ({"theta": -1}, r"theta must be a finite number in \[0.0, inf\), got -1"),
    ({"batch_size": 0}, "batch_size must be an integer >= 1, got 0"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="cmoead: " + text):
        CMOEAD(**kwargs)


def test_what_it_cannot_do_is_refused_with_its_name():
    with pytest.raises(AlgorithmConfigError, match="cmoead: budget=50 .* initial sample of 100"):
        run(CMOEAD(), PymooBenchmark("mw3"), budget=50)
    with pytest.raises(AlgorithmConfigError, match="cmoead: n_neighbors=30 exceeds the "
                                                   "population of 20"):
        CMOEAD(pop_size=20, n_neighbors=30).setup(PymooBenchmark("mw3"), budget=100, seed=0)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("cmoead")


def test_cli_run(tmp_path):
    metrics = cli_metrics(tmp_path, "problem=mw3", "algorithm=cmoead", "budget=40",
                          "algorithm.pop_size=20", "algorithm.batch_size=10")
    assert metrics["algorithm"] == "cmoead" and metrics["n_evals"] == 40
