"""KTS: its indicator, archives and diversity measure against their definitions, both
search modes, runs on the suites, seeds, bad input, config and CLI."""

from __future__ import annotations

import numpy as np
import pytest

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.kts import (
    CONSTRAINED,
    KTS,
    UNCONSTRAINED,
    Designs,
    diversity_archive,
    eps_fitness,
    eps_truncation,
    lp_distances,
    pure_diversity,
)
from tmopt.algorithms.operators.survival import farthest_points
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

from .contract import (
    algorithm_from_yaml,
    assert_seed_decides_the_archive,
    cli_metrics,
    drive_to_budget,
    run,
)
from .test_mgsaea import RBFDouble, TwoGroupProblem


def small(**kw) -> KTS:
    return KTS(**{"pop_size": 12, "wmax": 3, "n_elite": 5, "surrogate": RBFDouble, **kw})


# ---- I_eps+ fitness and truncation ----------------------------------------------------------
def _eps_fitness_by_definition(F: np.ndarray, alive: np.ndarray, kappa: float) -> np.ndarray:
    """IBEA's fitness of every row from the other alive rows, normalisation and scales of
    the whole set: -sum_{i alive, i != j} exp(-I(i, j) / (c_j kappa))."""
    lo, hi = F.min(axis=0), F.max(axis=0)
    Fn = (F - lo) / np.where(hi > lo, hi - lo, 1)
    n = len(F)
    eps = np.array([[max(Fn[i] - Fn[j]) for j in range(n)] for i in range(n)])
    c = np.abs(eps).max(axis=0)
    return np.array([-sum(np.exp(-eps[i, j] / c[j] / kappa) for i in range(n)
                          if alive[i] and i != j) for j in range(n)])


def test_eps_fitness_and_truncation_follow_ibea_definitions():
    rng = np.random.default_rng(3)
    F = rng.random((15, 3))
    alive = np.ones(15, dtype=bool)
    np.testing.assert_allclose(eps_fitness(F, 0.05), _eps_fitness_by_definition(F, alive, 0.05))
    keep = eps_truncation(F, 6, 0.05)
    # replay the deletions by the definition: each time the worst alive fitness goes
    for _ in range(15 - 6):
        fit = _eps_fitness_by_definition(F, alive, 0.05)
        alive[np.flatnonzero(alive)[np.argmin(fit[alive])]] = False
    assert keep.tolist() == np.flatnonzero(alive).tolist()


def test_a_dominated_point_has_the_worst_eps_fitness_and_goes_first():
    F = np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 0.5], [0.9, 0.9]])  # the last is dominated
    assert np.argmin(eps_fitness(F, 0.05)) == 3
    assert eps_truncation(F, 3, 0.05).tolist() == [0, 1, 2]


# ---- diversity archive, farthest points, pure diversity ---------------------------------
def test_diversity_archive_keeps_non_dominated_extremes_then_farthest():
    F = np.array([[0.0, 1.0], [0.1, 0.9], [0.5, 0.5], [0.52, 0.48], [1.0, 0.0], [0.9, 0.95]])
    assert diversity_archive(F, 10, 0.5).tolist() == [0, 1, 2, 3, 4]  # row 5 is dominated
    kept = diversity_archive(F, 3, 0.5).tolist()
    assert kept[:1] == [0] and 4 in kept and len(kept) == 3
    assert kept[1] in (2, 3)  # the middle, not the neighbour of an extreme


def test_farthest_points_adds_the_row_farthest_from_the_chosen_ones():
    x = np.array([[0.0], [1.0], [10.0], [4.0]])
    D = lp_distances(x, x, 1.0)
    grown = farthest_points(D, np.array([True, False, False, False]), 3)
    assert grown.tolist() == [True, False, True, True]


def test_pure_diversity_on_a_line_equals_the_recursive_definition():
    # PD(X) = max_s PD(X - s) + d(s, X - s): for 0, 1, 3 that is 3 (remove 3: 1 + 2)
    assert pure_diversity(np.array([[0.0], [1.0], [3.0]])) == pytest.approx(3.0)
    assert pure_diversity(np.array([[0.0], [2.0]])) == pytest.approx(2.0)
    assert pure_diversity(np.array([[0.0]])) == 0.0


def test_lp_distance_with_p_below_one():
    d = lp_distances(np.array([[0.0, 0.0]]), np.array([[1.0, 1.0]]), 0.5)
    assert d[0, 0] == pytest.approx(4.0)  # (1 + 1) ** 2


# ---- the two modes ---------------------------------------------------------------------------
def test_mode_follows_the_correlation_of_convergence_and_violation():
    alg = small(n_elite=2)  # the 3 best-converged rows: 0, 1, 2
    alg.setup(TwoGroupProblem(), budget=100, seed=0)
    F = np.column_stack([np.arange(10.0), np.arange(10.0)])  # a chain: row 0 best
    X = np.zeros((10, 4))

    def mode(cv):
        G = np.column_stack([cv, -np.ones(10), -np.ones(10)])
        alg._all = Designs.real(X, F, G)
        return alg._choose_mode()

    assert mode(np.arange(10.0)) == UNCONSTRAINED and alg.last_r > 0.6  # agree
    assert mode(9.0 - np.arange(10.0)) == CONSTRAINED and alg.last_r < -0.2  # conflict
    assert mode(np.zeros(10)) == UNCONSTRAINED and alg.last_r is None  # all feasible


def test_both_modes_run_and_every_proposal_is_new():
    problem = PymooBenchmark("mw3", n_var=6)
    for tau, phi in ((1.0, -1.0), (-1.0, 1.0)):  # constrained only / unconstrained only
        alg = small(tau=tau, phi=phi)
        ev = drive_to_budget(alg, problem, 12 + 30)
        X = ev.archive.data.X
        assert len(np.unique(X, axis=0)) == len(X)
        mode = alg.summary()["iterations"]
        assert set(k for k in mode if ":" not in k) == {
            CONSTRAINED if tau == 1.0 else UNCONSTRAINED}


def test_mw3_gets_feasible_designs_and_a_front():
    res = run(small(pop_size=30, wmax=5), PymooBenchmark("mw3", n_var=6), budget=90)
    assert res.metrics["feasible_ratio"] > 0 and res.metrics["igd"] is not None
    assert res.metrics["algorithm_summary"]["iterations"]


@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem = PymooBenchmark(name)
    n = problem.n_var + 2  # the RBF double interpolates with a linear tail: > n_var points
    drive_to_budget(small(pop_size=n, wmax=2), problem, n + 10)


def test_same_seed_same_archive():
    assert_seed_decides_the_archive(lambda: small(), PymooBenchmark("mw3", n_var=6), 40)


@pytest.mark.parametrize("kwargs, text", [
    ({"tau": 2.0}, r"tau must be a finite number in \[-1.0, 1.0\], got 2.0"),
    ({"n_elite": 1}, "n_elite must be an integer >= 2, got 1"),
    ({"n_infill": 0}, "n_infill must be an integer >= 1, got 0"),
    ({"uncertainty_share": 0.0}, r"uncertainty_share must be a finite number in \(0.0, 1.0\]"),
    ({"surrogate": "gp"}, "surrogate must be a zero-argument factory"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="kts: " + text):
        KTS(**kwargs)


def test_budget_below_the_initial_sample_is_refused():
    with pytest.raises(AlgorithmConfigError, match="kts: budget=50 .* initial sample of 100"):
        run(KTS(surrogate=RBFDouble), PymooBenchmark("mw3"), budget=50)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("kts")


def test_cli_run(tmp_path):
    metrics = cli_metrics(tmp_path, "problem=mw1", "problem.n_var=4", "algorithm=kts",
                          "surrogate=gp", "budget=30", "algorithm.pop_size=10",
                          "algorithm.wmax=2")
    assert metrics["algorithm"] == "kts" and metrics["n_evals"] == 30
