"""SSDE: the SOM by hand, only predicted survivors evaluated, stalls, failures, seeds."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.indicators.hv import HV

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.som import SelfOrganisingMap
from tmopt.algorithms.ssde import SSDE
from tmopt.evaluation.evaluator import EvaluatedBatch, Evaluator
from tmopt.metrics.indicators import constraint_violation
from tmopt.problems.base import ExpensiveProblem
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

from .contract import (
    algorithm_from_yaml,
    assert_seed_decides_the_archive,
    cli_metrics,
    drive_to_budget,
    run,
)


class ZDT1(ExpensiveProblem):
    """ZDT1 (Zitzler, Deb & Thiele 2000): unconstrained, so survivors vary in number."""

    def __init__(self, n_var: int = 5) -> None:
        super().__init__(n_var=n_var, n_obj=2, xl=0.0, xu=1.0, name="zdt1")

    def _evaluate(self, X, out, *args, **kwargs):
        g = 1.0 + 9.0 * X[:, 1:].mean(axis=1)
        out["F"] = np.column_stack([X[:, 0], g * (1.0 - np.sqrt(X[:, 0] / g))])


def som(n_nodes=5, n_var=2, n_out=1, epochs=1, sigma0=0.5, seed=0):
    return SelfOrganisingMap(n_nodes, n_var, n_out, eta0=0.2, sigma0=sigma0, epochs=epochs,
                             rng=np.random.default_rng(seed))


def test_som_prediction_is_the_output_part_of_the_nearest_node():
    m = som(n_nodes=3)
    m.W = np.array([[0.0, 0.0, 10.0], [1.0, 1.0, 20.0], [0.5, 0.0, 30.0]])
    pred = m.predict(np.array([[0.9, 0.8], [0.4, 0.1], [0.1, 0.0]]))
    assert pred[:, 0].tolist() == [20.0, 30.0, 10.0]
    assert m.won.tolist() == [True, True, True]


def test_som_first_win_copies_the_sample_then_the_neighbourhood_moves():
    m = som(n_nodes=3, sigma0=1.5)
    m.W = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [1.0, 1.0, 0.0]])
    s = np.array([[0.9, 0.9, 7.0]])
    m.train(s)
    assert np.allclose(m.W[2], s[0])          # winner: first win copies the sample
    # node 1 is 1 lattice step away (< sigma0 = 1.5): w += 0.2 * exp(-1) * (s - w)
    assert np.allclose(m.W[1], [0.5, 0.5, 0.0] + 0.2 * np.exp(-1) * (s[0] - [0.5, 0.5, 0.0]))
    assert np.allclose(m.W[0], [0.0, 0.0, 0.0])  # 2 steps away: outside the radius


def test_som_training_learns_a_smooth_function():
    rng = np.random.default_rng(0)
    X = rng.random((200, 2))
    y = X.sum(axis=1, keepdims=True)
    m = som(n_nodes=50, sigma0=50, epochs=50)
    m.train(np.hstack([X, y]))
    test = rng.random((200, 2))
    err = np.abs(m.predict(test)[:, 0] - test.sum(axis=1)).mean()
    assert err < 0.1  # 0.058 here; always predicting the mean 1.0 gives 0.30


def test_idle_nodes_are_reseeded_between_winners():
    m = som(n_nodes=4)
    m.W = np.array([[0.2, 0.2, 1.0], [0.8, 0.8, 3.0], [0.0, 1.0, 9.0], [1.0, 0.0, 9.0]])
    m.won[:] = [True, True, False, False]
    winners = m.W[:2].copy()
    m._reseed_idle_nodes()
    means = [(winners[i] + winners[j]) / 2 for i in range(2) for j in range(2)]
    for row in m.W[2:]:
        assert min(np.abs(row - mu).max() for mu in means) < 0.01


def step(alg, ev):
    X = alg.ask()
    if len(X):
        alg.tell(ev.evaluate(X[: ev.remaining]))
    return X


def test_only_children_predicted_to_survive_are_evaluated():
    problem = ZDT1()
    alg = SSDE(pop_size=20)
    alg.setup(problem, budget=400, seed=0)
    ev = Evaluator(problem, 400)
    sizes = []
    while ev.remaining and alg.has_next():
        before = alg.X.copy() if alg.X is not None else None
        X = step(alg, ev)
        sizes.append(min(len(X), 400 - sum(sizes)))  # the last batch is cut to the budget
        if before is not None:  # the evaluated children replaced exactly as many parents
            changed = np.any(alg.X != before, axis=1)
            assert changed.sum() <= len(X)
            assert {tuple(x) for x in alg.X[changed]} <= {tuple(x) for x in X}
    assert sizes[0] == 20 and max(sizes[1:]) <= 20
    assert min(sizes[1:]) < 20  # some generations evaluate fewer than N
    assert sum(sizes) == alg.n_evals == len(ev.archive) == 400


def test_beats_random_sampling_on_an_unconstrained_problem():
    hv = HV(ref_point=np.array([1.1, 1.1]))
    res = run(SSDE(pop_size=20), ZDT1(), budget=400, seed=0)
    random = ZDT1().evaluate(np.random.default_rng(0).random((400, 5)))
    # seeds 0-2: SSDE 0.45-0.82, random 0.00-0.04
    assert hv(res.archive.F) > hv(random) + 0.3


def test_predicted_children_count_as_feasible_so_all_replace_an_infeasible_population():
    problem = PymooBenchmark("mw1", n_var=6)
    alg = SSDE(pop_size=20)
    alg.setup(problem, budget=200, seed=0)
    ev = Evaluator(problem, 200)
    step(alg, ev)
    assert np.all(constraint_violation(alg.G) > 0)  # MW1 random designs are infeasible
    assert len(step(alg, ev)) == 20


def test_modelled_constraints_are_predicted_and_used():
    problem = PymooBenchmark("mw1", n_var=6)
    alg = SSDE(pop_size=20, model_constraints=True)
    res = run(alg, problem, budget=300)
    assert alg.som.W.shape[1] == 6 + 2 + 1 and len(res.archive) == 300


def test_no_surviving_child_stops_the_run_cleanly():
    alg = SSDE(pop_size=10, max_idle=3)
    problem = ZDT1(n_var=4)
    alg.setup(problem, budget=100, seed=0)
    ev = Evaluator(problem, 100)
    step(alg, ev)
    alg.som.predict = lambda Xn: np.full((len(Xn), 2), 1e9)  # every child looks hopeless
    assert len(step(alg, ev)) == 0 and not alg.has_next()
    assert alg.n_trainings == 3  # retrained on the population after each empty generation


def test_failed_designs_are_never_training_samples():
    problem = PymooBenchmark("mw3", n_var=4)
    alg = SSDE(pop_size=4)
    alg.setup(problem, budget=100, seed=0)
    X = alg.ask()
    failed = np.array([False, True, False, True])
    alg.tell(EvaluatedBatch(X=X, F=np.ones((4, 2)), G=np.ones((4, 2)), failed=failed,
                            reason=["", "boom", "", "boom"]))
    assert len(alg._samples) == 2
    assert np.allclose(alg._samples[:, :4], X[~failed])  # bounds are [0, 1]


@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem, alg = PymooBenchmark(name), SSDE(pop_size=10)
    drive_to_budget(alg, problem, alg.initial_sample_size(problem) + 20)


def test_same_seed_same_archive():
    assert_seed_decides_the_archive(lambda: SSDE(pop_size=20), PymooBenchmark("mw3", n_var=6),
                                    budget=200)


@pytest.mark.parametrize("kwargs, text", [
    ({"pop_size": 1}, "pop_size must be an integer >= 2, got 1"),
    ({"eta0": 0}, r"eta0 must be a finite number in \(0.0, 1.0\], got 0"),
    ({"sigma0": -2.0}, r"sigma0 must be a finite number in \(0.0, inf\), got -2.0"),
    ({"epochs": 0}, "epochs must be an integer >= 1, got 0"),
    ({"de_cr": 1.5}, r"de_cr must be a finite number in \[0.0, 1.0\], got 1.5"),
    ({"n_nodes": 0}, "n_nodes must be an integer >= 1, got 0"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="ssde: " + text):
        SSDE(**kwargs)


def test_budget_below_the_population_is_refused():
    with pytest.raises(AlgorithmConfigError, match="ssde: budget=50 .* initial sample of 100"):
        run(SSDE(), PymooBenchmark("mw3"), budget=50)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("ssde")


def test_cli_run(tmp_path):
    metrics = cli_metrics(tmp_path, "problem=mw3", "algorithm=ssde", "budget=60",
                          "algorithm.pop_size=20")
    assert metrics["algorithm"] == "ssde" and metrics["n_evals"] == 60


def test_reseed_first_nodes_takes_platemos_parents():
    # Training.m draws k in 1..(number of winners) and averages W(k, :): the first nodes of
    # the map, here idle ones, instead of the winners 3 and 4
    def reseeded(first: bool) -> np.ndarray:
        m = SelfOrganisingMap(5, 2, 1, eta0=0.2, sigma0=0.5, epochs=1,
                              rng=np.random.default_rng(0), reseed_first_nodes=first)
        m.W = np.column_stack([np.full((5, 2), 0.5), [1.0, 2.0, 3.0, 50.0, 60.0]])
        m.won[:] = [False, False, False, True, True]
        m._reseed_idle_nodes()
        return m.W[:3, 2]

    fixed, platemo = reseeded(False), reseeded(True)
    assert np.all((fixed > 49.9) & (fixed < 60.1))    # means of winners 50 and 60
    assert np.all((platemo > 0.9) & (platemo < 2.1))  # means of nodes 0 and 1 (1 and 2)
    alg = SSDE(pop_size=10, reference="platemo")
    assert alg.reseed_first_nodes
    res = run(alg, PymooBenchmark("mw3", n_var=4), budget=60)
    assert alg.som.reseed_first_nodes and len(res.archive) <= 60
    with pytest.raises(AlgorithmConfigError, match="ssde: reference must be one of "
                                                   "tmopt, platemo, got 'x'"):
        SSDE(reference="x")
