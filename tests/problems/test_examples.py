"""The worked example of docs/adding-a-problem.md is real: it builds, runs and is correct."""

import numpy as np
import pytest

from tmopt.algorithms.nsga2 import NSGA2
from tmopt.metrics import igd
from tmopt.problems.examples import BinhKorn
from tmopt.problems.fronts.sampling import nondominated_index
from tmopt.run.cli import preflight
from tmopt.run.runner import run_optimisation

DOCUMENTED = ["problem=binh_korn", "algorithm=nsga2", "budget=1000"]


def test_documented_command_passes_preflight():
    assert preflight(DOCUMENTED) == 1
    assert preflight(DOCUMENTED + ["problem.grouped=false"]) == 1


def test_documented_run_approaches_the_front(tmp_path):
    problem = BinhKorn()
    result = run_optimisation(problem, NSGA2(), budget=1000, seed=0, outdir=tmp_path,
                              progress=False, plots=False)
    assert (tmp_path / "archive.h5").exists() and (tmp_path / "metrics.json").exists()
    front = problem.pareto_front()
    first = result.archive.F[:100]  # the random initial sample
    assert result.metrics["igd"] < igd(first, front) / 5


def test_front_is_feasible_non_dominated_and_not_beaten_by_random_designs():
    p = BinhKorn(front_points=300)
    front = p.pareto_front()
    G = p.evaluate(p.pareto_set(300), return_as_dictionary=True)["G"]
    assert G.max() <= 0.0  # feasible; g1 = 0 only at the end point x = (0, 0)
    assert len(nondominated_index(front)) == len(front)
    X = p.xl + np.random.default_rng(1).random((50_000, 2)) * (p.xu - p.xl)
    out = p.evaluate(X, return_as_dictionary=True)
    F = out["F"][np.all(out["G"] <= 0, axis=1)]
    nd = nondominated_index(np.vstack([front, F + 1e-9]))
    assert np.isin(np.arange(len(front)), nd).all()
    # the extreme points: x = (0, 0) and x = (5, 3)
    np.testing.assert_allclose(front[[0, -1]], [[0.0, 50.0], [136.0, 4.0]])


def test_groups_and_bad_input():
    assert BinhKorn().key_constraint_indices().tolist() == [0]
    assert BinhKorn(grouped=False).key_constraint_indices().tolist() == [0, 1]
    with pytest.raises(ValueError, match="problem bnh: front_points must be an integer >= 2"):
        BinhKorn(front_points=1)
