"""Suite problems: configs, sizes from config, bad input, constraint groups, no network."""

from pathlib import Path

import numpy as np
import pytest
from pymoo.problems import get_problem

from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark, default_n_var
from tmopt.run.cli import preflight
from tmopt.run.config import ConfigError

CONF = Path(__file__).resolve().parents[2] / "tmopt" / "conf" / "problem"


def test_every_suite_problem_has_a_config_and_every_config_builds():
    names = sorted(p.stem for p in CONF.glob("*.yaml") if not p.stem.startswith("stiffness"))
    assert set(SUITE_PROBLEMS) <= set(names)
    # the configs are under test, not the algorithm: NSGA-II needs only its population
    assert preflight([f"problem={','.join(names)}", "algorithm=nsga2", "budget=300"]) == len(names)


def test_paper_setting_d10_from_the_command_line():
    # the expensive comparisons use D = 10 (MW1, MW3, MW7, C1-DTLZ1, C2-DTLZ2)
    assert preflight(["problem=mw1,mw3,mw7,c1dtlz1,c2dtlz2", "problem.n_var=10"]) == 5
    assert preflight(["problem=c2dtlz2", "problem.n_obj=5"]) == 1
    assert preflight(["problem=dascmop7", "problem.difficulty=[0.5,0.5,0.25]"]) == 1


@pytest.mark.parametrize("name", list(SUITE_PROBLEMS))
def test_each_problem_evaluates_a_batch(name):
    p = PymooBenchmark(name, n_var=10)
    X = p.xl + np.random.default_rng(0).random((8, 10)) * (p.xu - p.xl)
    out = p.evaluate(X, return_as_dictionary=True)
    assert out["F"].shape == (8, p.n_obj) and out["G"].shape == (8, p.n_ieq_constr)
    assert np.all(np.isfinite(out["F"])) and np.all(np.isfinite(out["G"]))


@pytest.mark.parametrize("name, n_obj, n_var", [
    ("mw3", 2, 15), ("mw14", 3, 15), ("c1dtlz1", 3, 7), ("c3dtlz1", 3, 7), ("c2dtlz2", 3, 12),
    ("c1dtlz3", 3, 12), ("c3dtlz4", 3, 12), ("c2dtlz2", 5, 14), ("dascmop1", 2, 30),
])
def test_published_default_sizes(name, n_obj, n_var):
    assert default_n_var(name, n_obj) == n_var
    p = PymooBenchmark(name, n_obj=n_obj if name != "mw3" and name != "dascmop1" else None)
    assert (p.n_var, p.n_obj) == (n_var, n_obj)


def test_dascmop_n_var_from_config_reaches_pymoo():
    p = PymooBenchmark("dascmop4", n_var=10)
    assert p.inner.n_var == 10 and p.xl.shape == (10,)
    # g2 sums over x_2..x_n: 9 terms, each 0 at x = 0.5, so x_1 = 0.3 gives F = (0.3, 0.91)
    X = np.full((1, 10), 0.5)
    X[0, 0] = 0.3
    F = p.evaluate(X, return_as_dictionary=True)["F"]
    np.testing.assert_allclose(F, [[0.3, 1 - 0.09]], atol=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    ({"name": "zdt1"}, "'zdt1' is not a suite problem"),
    ({"name": "mw3", "n_var": 2}, r"mw3: n_var must be an integer >= 3"),
    ({"name": "mw3", "n_var": 10.5}, "n_var"),
    ({"name": "mw3", "n_obj": 3}, "mw3: n_obj must be 2"),
    ({"name": "c2dtlz2", "n_obj": 1}, "n_obj must be an integer >= 2"),
    ({"name": "mw3", "difficulty": 4}, "difficulty applies to DAS-CMOP only"),
    ({"name": "dascmop2", "difficulty": 17}, "dascmop2: DAS-CMOP difficulty must be"),
    ({"name": "dascmop2", "difficulty": [0.1, 0.2]}, "three values in"),
    ({"name": "mw1", "constraint_groups": "pairs"}, "constraint_groups must be null or 'split'"),
    ({"name": "mw1", "front_points": 3}, "front_points must be an integer >= 10"),
])
def test_bad_input_names_problem_and_range(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PymooBenchmark(**kwargs)


def test_bad_config_value_is_one_line_config_error():
    with pytest.raises(ConfigError, match="problem=mw3: problem mw3: n_var must be"):
        preflight(["problem=mw3", "problem.n_var=1"])


def test_constraint_groups_single_or_split():
    single = PymooBenchmark("mw11")
    assert len(single.constraint_groups) == 1
    assert single.key_constraint_indices().tolist() == [0, 1, 2, 3]
    split = PymooBenchmark("mw11", constraint_groups="split")
    assert [g.priority for g in split.constraint_groups] == [0, 1, 2, 3]
    assert split.key_constraint_indices().tolist() == [0]
    assert split.describe()["constraint_grouping"] == "split"


def test_fronts_never_touch_the_network():
    # conftest.py's autouse guard replaces sockets, urllib and pymoo's downloader in every
    # test of this folder, so each front computed in these tests was computed offline.
    # The guard works: pymoo's own MW7 and DAS-CMOP fronts are downloads.
    for name, args in (("mw7", ()), ("dascmop1", (8,))):
        with pytest.raises(AssertionError, match="network access attempted"):
            get_problem(name, *args).pareto_front()
    for name in SUITE_PROBLEMS:
        F = PymooBenchmark(name, front_points=300).pareto_front()
        assert F.ndim == 2 and len(F) >= 10, name
