"""ExpensiveProblem: bounds, sizes and constraint-group validation with clear messages."""

import numpy as np
import pytest

from tmopt.problems.base import ConstraintGroup, ExpensiveProblem


class Square(ExpensiveProblem):
    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = np.column_stack([X[:, 0] ** 2, (X[:, 0] - 1) ** 2])
        if self.n_ieq_constr:
            out["G"] = np.repeat(X[:, :1] - 0.5, self.n_ieq_constr, axis=1)


def test_scalar_bounds_are_broadcast_and_evaluation_is_vectorised():
    p = Square(n_var=3, n_obj=2, n_ieq_constr=2, xl=-1.0, xu=2.0, name="sq")
    np.testing.assert_array_equal(p.xl, [-1, -1, -1])
    out = p.evaluate(np.array([[0.0, 0, 0], [1.0, 0, 0]]), return_as_dictionary=True)
    np.testing.assert_allclose(out["F"], [[0, 1], [1, 0]])
    assert out["G"].shape == (2, 2)


def test_lower_bound_not_below_upper_is_refused_naming_variable():
    with pytest.raises(ValueError, match=r"problem sq: .*variable 1 has xl=\S*2\.0\S* >= xu="):
        Square(n_var=2, n_obj=2, xl=[0.0, 2.0], xu=[1.0, 2.0], name="sq")
    with pytest.raises(ValueError, match="variable 0"):
        Square(n_var=1, n_obj=2, xl=3.0, xu=1.0, name="sq")


@pytest.mark.parametrize("xl, xu, match", [
    ([0.0, 0.0, 0.0], 1.0, r"xl has shape \(3,\), expected \(2,\)"),
    (0.0, [[1.0, 1.0]], r"xu has shape \(1, 2\)"),
    ([0.0, np.nan], 1.0, "finite"),
    (0.0, [1.0, np.inf], "finite"),
])
def test_bound_shapes_and_values_are_checked(xl, xu, match):
    with pytest.raises(ValueError, match=match):
        Square(n_var=2, n_obj=2, xl=xl, xu=xu, name="sq")


@pytest.mark.parametrize("kwargs, match", [
    ({"n_var": 0}, "n_var must be an integer >= 1"),
    ({"n_var": 2.5}, "n_var"),
    ({"n_var": True}, "n_var"),
    ({"n_obj": 0}, "n_obj"),
    ({"n_ieq_constr": -1}, "n_ieq_constr must be an integer >= 0"),
])
def test_sizes_are_checked(kwargs, match):
    args = {"n_var": 2, "n_obj": 2, **kwargs}
    with pytest.raises(ValueError, match=match):
        Square(name="sq", **args)


def test_default_single_group_and_no_group_without_constraints():
    p = Square(n_var=1, n_obj=2, n_ieq_constr=3, name="sq")
    assert [g.name for g in p.constraint_groups] == ["all"]
    assert p.key_constraint_indices().tolist() == [0, 1, 2] and not p.has_declared_groups
    q = Square(n_var=1, n_obj=2, name="sq")
    assert q.constraint_groups == () and q.key_constraint_indices().size == 0


def test_key_individual_is_the_smallest_priority():
    groups = [ConstraintGroup("TM2", (2, 3), 1), ConstraintGroup("TM1", (0, 1), 0)]
    p = Square(n_var=1, n_obj=2, n_ieq_constr=4, name="sq", constraint_groups=groups)
    assert p.has_declared_groups and p.key_constraint_indices().tolist() == [0, 1]
    tied = [ConstraintGroup("a", (0,), 0), ConstraintGroup("b", (1,), 0)]
    p2 = Square(n_var=1, n_obj=2, n_ieq_constr=2, name="sq", constraint_groups=tied)
    assert p2.key_constraint_indices().tolist() == [0, 1]


@pytest.mark.parametrize("groups", [
    [ConstraintGroup("a", (0,), 0)],                                   # column 1 missing
    [ConstraintGroup("a", (0, 1), 0), ConstraintGroup("b", (1,), 1)],  # column 1 twice
    [ConstraintGroup("a", (0, 1, 2), 0)],                              # no column 2
])
def test_groups_must_cover_each_column_once(groups):
    with pytest.raises(ValueError, match="problem sq: constraint_groups must cover each of the 2"):
        Square(n_var=1, n_obj=2, n_ieq_constr=2, name="sq", constraint_groups=groups)


def test_label_lengths_are_checked_and_describe_reports_groups():
    with pytest.raises(ValueError, match="objective_names has 1 entries, expected n_obj=2"):
        Square(n_var=1, n_obj=2, name="sq", objective_names=["a"])
    with pytest.raises(ValueError, match="constraint_names"):
        Square(n_var=1, n_obj=2, n_ieq_constr=1, name="sq", constraint_names=["a", "b"])
    p = Square(n_var=1, n_obj=2, n_ieq_constr=2, name="sq",
               constraint_groups=[ConstraintGroup("TM1", (1, 0), 0)])
    d = p.describe()
    assert d["name"] == "sq" and d["n_constr"] == 2
    assert d["constraint_groups"] == [{"name": "TM1", "indices": [1, 0], "priority": 0}]
