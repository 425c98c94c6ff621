"""MGSAEA, MGSAEA-IPC and MGSAEA*: stages, granularity, budget, reproducibility, bad input.

The surrogate here is a test double (scipy's thin-plate RBF interpolator behind the
:class:`Surrogate` interface) so these tests stay fast; the GP default is exercised in
test_mgsaea_gp.py.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from scipy.interpolate import RBFInterpolator

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.mgsaea import (
    MGSAEA,
    MGSAEAIPC,
    AlgorithmStateError,
    MGSAEAStar,
    ModelPlan,
    _Set,
    minmax_scaling,
    violation_scale,
)
from tmopt.algorithms.operators.stage import change_rate
from tmopt.metrics.indicators import constraint_violation
from tmopt.metrics.selection import best_compromise
from tmopt.problems.base import ConstraintGroup, ExpensiveProblem
from tmopt.problems.suites import PymooBenchmark
from tmopt.run.outputs import final_choice
from tmopt.surrogates.base import Surrogate

from .contract import algorithm_from_yaml, run


class RBFDouble(Surrogate):
    """Thin-plate RBF interpolation: a cheap, deterministic stand-in for a GP."""

    name = "rbf_double"
    widths: list[int] = []

    def fit(self, X, Y):
        X, Y = self.check_training_data(X, Y)
        RBFDouble.widths.append(Y.shape[1])
        self.model = RBFInterpolator(X, Y, kernel="thin_plate_spline", smoothing=1e-8)
        return self

    def predict(self, X):
        mean = self.model(np.asarray(X, dtype=float))
        return mean, np.zeros_like(mean)


class TwoGroupProblem(ExpensiveProblem):
    """2 objectives, 3 constraints; TM1 (key, priority 0) owns g3, TM2 owns g1 and g2."""

    def __init__(self, n_var: int = 4) -> None:
        super().__init__(n_var=n_var, n_obj=2, n_ieq_constr=3, xl=0.0, xu=1.0,
                         name="two_group",
                         constraint_groups=[ConstraintGroup("TM2", (0, 1), 1),
                                            ConstraintGroup("TM1", (2,), 0)])

    def _evaluate(self, X, out, *args, **kwargs):
        f1 = X[:, 0]
        f2 = 1.0 - np.sqrt(X[:, 0]) + np.sum((X[:, 1:] - 0.5) ** 2, axis=1)
        out["F"] = np.column_stack([f1, f2])
        out["G"] = np.column_stack([0.3 - X[:, 1], X[:, 2] - 0.8, 0.5 - X[:, 3]])


def small(cls=MGSAEA, **kw):
    defaults = {"n_init": 20, "wmax": 5, "surrogate": RBFDouble}
    return cls(**{**defaults, **kw})


# ---- bad input -------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, text", [
    ({"wmax": -1}, "wmax must be an integer >= 0, got -1"),
    ({"mu": 0}, "mu must be an integer >= 1, got 0"),
    ({"gap": 2.5}, "gap must be an integer >= 1, got 2.5"),
    ({"threshold": 0.0}, "threshold must be a positive finite number, got 0.0"),
    ({"sigma": float("nan")}, "sigma must be a positive finite number"),
    ({"n_init": 1}, "n_init must be an integer >= 2, got 1"),
    ({"surrogate": "gp"}, "surrogate must be a zero-argument factory"),
])
def test_bad_arguments_name_the_algorithm_and_value(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="algorithm mgsaea: " + text.split(",")[0]):
        MGSAEA(**kwargs)


def test_budget_below_the_lhs_sample_is_refused_with_the_numbers():
    problem = PymooBenchmark("mw3", n_var=10)
    with pytest.raises(AlgorithmConfigError,
                       match=r"mgsaea_ipc: budget=100 .* initial sample of 109"):
        run(MGSAEAIPC(surrogate=RBFDouble), problem, budget=100)


def test_ipc_without_groups_and_without_fallback_is_refused():
    problem = PymooBenchmark("mw3", n_var=10)
    alg = MGSAEAIPC(surrogate=RBFDouble, ungrouped="error")
    with pytest.raises(AlgorithmConfigError, match="mgsaea_ipc: problem mw3 declares no "
                                                   "constraint groups"):
        alg.check_budget(problem, 300)
    with pytest.raises(AlgorithmConfigError, match="ungrouped must be 'first' or 'error'"):
        MGSAEAIPC(ungrouped="half")


# ---- what each variant models in stage one --------------------------------------------------
@pytest.mark.parametrize("cls, n_outputs, con", [
    (MGSAEA, 2, ()),            # objectives only
    (MGSAEAIPC, 3, (2,)),       # + the key individual's constraint g3 (TM1)
    (MGSAEAStar, 5, (0, 1, 2)),  # + every constraint
])
def test_stage_one_models_per_variant(cls, n_outputs, con):
    RBFDouble.widths = []
    alg = small(cls)
    run(alg, TwoGroupProblem(), budget=30)
    assert alg.stage == 1 and alg.iteration == 2
    assert set(RBFDouble.widths) == {n_outputs}
    assert alg._plan.con == con
    assert alg.info()["models"] == n_outputs


def test_ipc_says_its_fallback_on_an_ungrouped_problem_once(caplog, monkeypatch):
    import tmopt.algorithms.mgsaea as mgsaea

    monkeypatch.setattr(mgsaea, "_FALLBACK_SAID", set())  # a fresh process
    problem = PymooBenchmark("mw3", n_var=4)
    for _ in range(3):  # three runs of a sweep in one process
        MGSAEAIPC(surrogate=RBFDouble, pop_size=10, n_init=20).setup(problem, budget=30,
                                                                       seed=0)
    said = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert len(said) == 1 and "problem mw3 declares no constraint groups" in said[0]
    assert "its first constraint (g1) is taken as the key individual's" in said[0]
    caplog.clear()
    MGSAEAIPC(surrogate=RBFDouble, pop_size=10, n_init=20).setup(
        PymooBenchmark("mw3", n_var=4, constraint_groups="split"), budget=30, seed=0)
    assert "declares no constraint groups" not in caplog.text


def test_ipc_key_group_follows_declared_priority_and_split_grouping():
    alg = MGSAEAIPC()
    assert alg.stage_one_indices(TwoGroupProblem()) == (2,)
    assert alg.stage_one_indices(PymooBenchmark("mw3", n_var=10,
                                                constraint_groups="split")) == (0,)
    assert alg.stage_one_indices(PymooBenchmark("mw3", n_var=10)) == (0,)  # ungrouped=first
    assert MGSAEAStar().stage_one_indices(TwoGroupProblem()) == (0, 1, 2)


# ---- stage switch and granularity -----------------------------------------------------------
def test_stage_switch_after_gap_iterations_when_mc_is_below_threshold():
    alg = small(MGSAEAIPC, gap=2, threshold=1e9)  # any change rate switches
    run(alg, TwoGroupProblem(), budget=20 + 4 * 5)
    assert alg.stage == 2
    assert len(alg._ideal) == 4 and alg.last_mc is not None
    assert alg.info()["granularity"] in ("coarse", "fine", "objectives")

    never = small(MGSAEAIPC, gap=2, threshold=1e-300)
    run(never, TwoGroupProblem(), budget=20 + 4 * 5)
    assert never.stage == 1


def test_summary_reports_the_stage_reached_the_switch_and_the_change_rates():
    alg = small(MGSAEAIPC, gap=2, threshold=1e9)  # the first measured mc switches
    res = run(alg, TwoGroupProblem(), budget=20 + 4 * 5)
    summary = res.metrics["algorithm_summary"]
    # iterations 1-2 record ideal points; the 3rd measures mc against the 1st and switches
    assert summary["stage_reached"] == 2 and summary["switch_iteration"] == 3
    assert summary["iterations"] == 4 and summary["stage_two_possible"]
    mc = change_rate(alg._ideal[2], alg._ideal[0], sigma=alg.sigma)
    assert summary["mc"] == {"n": 1, "first": mc, "last": mc, "min": mc, "median": mc,
                             "max": mc}
    # stage two's granularity follows the population each iteration (choose_granularity),
    # so iterations 3 and 4 may differ: the summary counts each iteration's own plan
    counts = summary["granularity_iterations"]
    assert counts == dict(Counter(alg._granularities))
    assert sum(counts.values()) == 4 and counts["stage1:key"] == 2
    assert {k.split(":")[1] for k in counts if k.startswith("stage2:")} <= {
        "coarse", "fine", "objectives"}
    assert f"stage2:{alg.info()['granularity']}" in counts  # the last iteration's

    never = small(MGSAEAIPC, gap=2, threshold=1e-300)
    summary = run(never, TwoGroupProblem(), budget=20 + 4 * 5).metrics["algorithm_summary"]
    assert summary["stage_reached"] == 1 and summary["switch_iteration"] is None
    assert summary["mc"]["n"] == 2 and summary["granularity_iterations"] == {"stage1:key": 4}
    short = small(MGSAEAIPC, gap=20)
    summary = run(short, TwoGroupProblem(), budget=20 + 4 * 5).metrics["algorithm_summary"]
    assert summary["mc"] is None and not summary["stage_two_possible"]


def _stage_two(G: np.ndarray) -> ModelPlan:
    alg = small(MGSAEA)
    alg.setup(TwoGroupProblem(), budget=100, seed=0)
    alg._pop = _Set(np.zeros((len(G), 4)), np.zeros((len(G), 2)), G)
    alg.stage = 2
    return alg._make_plan()


def test_stage_two_granularity_plans():
    coarse = _stage_two(np.array([[1.0, -1.0, -1.0], [-1.0, 2.0, 0.0], [-1, -1, 4.0]]))
    assert (coarse.granularity, coarse.mode, coarse.con, coarse.aggregate) == \
        ("coarse", "cdp", (0, 1, 2), True)
    fine = _stage_two(np.array([[1.0, -1.0, -1.0], [-1.0, -2.0, 0.0]]))
    assert (fine.granularity, fine.mode, fine.con, fine.aggregate) == ("fine", "fine", (0,),
                                                                       False)
    assert fine.pop_con == (0, 1, 2)  # the real population is ranked on every constraint
    feas = _stage_two(-np.ones((2, 3)))
    assert (feas.granularity, feas.mode, feas.con, feas.pop_mode) == \
        ("objectives", "pareto", (), "cdp")


def test_coarse_target_is_scaled_violation_that_keeps_feasible_at_zero():
    G = np.array([[2.0, -1.0], [1.0, 4.0], [-3.0, -1.0]])
    scale = violation_scale(G)
    assert scale.tolist() == [2.0, 4.0]
    plan = ModelPlan("coarse", "cdp", (0, 1), True, "cdp", (0, 1), scale)
    Y = plan.targets(np.zeros((3, 2)), G)
    assert np.allclose(Y[:, 2], [1.0, 0.5 + 1.0, 0.0])  # min-max would zero row 0 too


# ---- runs ------------------------------------------------------------------------------------
def test_ipc_on_mw3_budget_150_runs_end_to_end_and_reaches_feasibility():
    problem = PymooBenchmark("mw3", n_var=10)
    alg = MGSAEAIPC(surrogate=RBFDouble)
    res = run(alg, problem, budget=150)
    assert len(res.archive) == 150
    assert res.metrics["feasible_ratio"] > 0
    # every design was sent once: no budget spent on re-evaluations
    assert len(np.unique(res.archive.X, axis=0)) == 150
    assert len(alg.elite["X"]) <= alg.pop_size


def test_same_seed_same_archive_other_seed_other_archive():
    problem = TwoGroupProblem()
    a = run(small(MGSAEAIPC), problem, budget=40, seed=3)
    b = run(small(MGSAEAIPC), problem, budget=40, seed=3)
    c = run(small(MGSAEAIPC), problem, budget=40, seed=4)
    assert np.array_equal(a.archive.X, b.archive.X)
    assert np.array_equal(a.archive.F, b.archive.F)
    assert not np.array_equal(a.archive.X, c.archive.X)


def test_population_stays_ni_and_elite_set_is_cut_to_n():
    alg = small(MGSAEA, pop_size=10)
    run(alg, TwoGroupProblem(), budget=40)
    assert len(alg._pop) == 20
    assert len(alg.elite["X"]) == 10


def test_max_iter_ends_the_run_before_the_budget():
    res = run(small(MGSAEA, max_iter=2), TwoGroupProblem(), budget=100)
    assert len(res.archive) == 20 + 2 * 5


def test_chosen_design_is_eq21_among_feasible_non_dominated_real_evaluations():
    # The run, not the algorithm, chooses (outputs.final_choice): from every real
    # evaluation, not from MGSAEA's elite set.
    res = run(small(MGSAEAStar), TwoGroupProblem(), budget=60)
    data, chosen = res.archive, res.metrics["chosen"]
    assert chosen["index"] == final_choice(data)[1]
    feas = ~data.failed & (constraint_violation(data.G) <= 0)
    assert chosen["feasible"] == bool(feas.any())
    if chosen["feasible"]:
        F = data.F[feas]
        nd = ~np.array([np.any(np.all(F <= f, axis=1) & np.any(F < f, axis=1)) for f in F])
        assert np.array_equal(data.F[chosen["index"]], F[nd][best_compromise(F[nd])])


class FailingProblem(TwoGroupProblem):
    """Designs with x1 > 0.8 fail (NaN objectives)."""

    def _evaluate(self, X, out, *args, **kwargs):
        super()._evaluate(X, out)
        out["F"][X[:, 0] > 0.8] = np.nan


def test_failed_designs_stay_out_of_the_training_data():
    alg = small(MGSAEAIPC)
    res = run(alg, FailingProblem(), budget=40)
    assert res.archive.failed.any()
    assert np.all(alg._pop.X[:, 0] <= 0.8)
    assert np.all(np.isfinite(alg._pop.F))


class AlwaysFails(TwoGroupProblem):
    def _evaluate(self, X, out, *args, **kwargs):
        super()._evaluate(X, out)
        out["F"][:] = np.nan


def test_a_problem_that_always_fails_ends_with_a_clear_error():
    with pytest.raises(AlgorithmStateError, match="mgsaea: only 0 successful evaluation"):
        run(small(MGSAEA), AlwaysFails(), budget=40)


class Unconstrained(ExpensiveProblem):
    def __init__(self) -> None:
        super().__init__(n_var=3, n_obj=2, n_ieq_constr=0, name="zdt_like")

    def _evaluate(self, X, out, *args, **kwargs):
        out["F"] = np.column_stack([X[:, 0], 1 - X[:, 0] + X[:, 1:].sum(axis=1)])


@pytest.mark.parametrize("cls", [MGSAEA, MGSAEAIPC, MGSAEAStar])
def test_unconstrained_problem_runs_every_variant(cls):
    alg = small(cls, n_init=12, gap=1, threshold=1e9)
    res = run(alg, Unconstrained(), budget=27)
    assert len(res.archive) == 27 and alg.stage == 2
    assert alg.info()["granularity"] == "objectives" and alg.info()["models"] == 2


@pytest.mark.parametrize("name", ["mgsaea", "mgsaea_ipc", "mgsaea_star"])
def test_yaml_matches_the_constructor(name):
    algorithm_from_yaml(name, surrogate=RBFDouble)


# ---- reference="platemo": PlatEMO's behaviour for each documented fix --------------------
def test_platemo_change_rate_has_no_absolute_value_and_explodes_on_negative_ideals():
    # quirk 1: a negative ideal component makes PlatEMO's denominator its delta
    assert change_rate([-1.001], [-1.0], sigma=1e-6, absolute=False) == pytest.approx(1e3)
    assert change_rate([-1.001], [-1.0], sigma=1e-6) == pytest.approx(1e-3)
    assert change_rate([2.002], [2.0], sigma=1e-6, absolute=False) == pytest.approx(1e-3)


def test_platemo_minmax_scaling_maps_the_least_violating_design_to_feasible():
    # quirk 3, NormalizeCV: (max(0, g) - min) / (max - min) per constraint, 0 where constant
    G = np.array([[2.0, -1.0, 5.0], [1.0, 4.0, 5.0], [-3.0, -1.0, 5.0]])
    plan = ModelPlan("coarse", "cdp", (0, 1, 2), False, "cdp", (0, 1, 2),
                     **minmax_scaling(G))
    np.testing.assert_allclose(plan.targets(np.zeros((3, 1)), G)[:, 1:],
                               [[1.0, 0.0, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 0.0]])
    # every design violates the third constraint by 5, yet all count as satisfying it


def test_reference_platemo_sets_every_documented_quirk_and_nothing_else():
    alg = small(MGSAEAIPC, reference="platemo", sigma=1e-3, normalise=True)
    assert (alg.abs_change_rate, alg.sigma, alg.violation_scaling, alg.skip_evaluated,
            alg.normalise) == (False, 1e-6, "minmax", False, False)
    assert (alg.gap, alg.threshold, alg.wmax, alg.mu) == (small(MGSAEAIPC).gap, 1e-3,
                                                         small(MGSAEAIPC).wmax, 5)
    with pytest.raises(AlgorithmConfigError, match="reference must be one of tmopt, "
                                                   "platemo, got 'matlab'"):
        small(MGSAEA, reference="matlab")
    with pytest.raises(AlgorithmConfigError, match="violation_scaling must be 'max' or"):
        small(MGSAEA, violation_scaling="minmax2")


def test_platemo_may_send_an_already_evaluated_design_tmopt_never_does():
    # quirk 4: the surrogate population starts from the real one, so its survivors can be
    # designs already evaluated; here every candidate is
    for skip in (False, True):
        alg = small(MGSAEA, skip_evaluated=skip, mu=2)
        alg.setup(TwoGroupProblem(), budget=100, seed=0)
        X = alg.rng.random((6, 4))
        alg._seen = X.copy()
        P = np.column_stack([np.arange(6.0), -np.arange(6.0)])  # all non-dominated
        chosen = alg._choose_infill(ModelPlan("objectives", "pareto"), X, P)
        assert len(chosen) == 2
        assert alg._already_seen(chosen).all() == (not skip)


def test_reference_platemo_runs_end_to_end():
    alg = small(MGSAEAIPC, reference="platemo")
    res = run(alg, PymooBenchmark("mw3", n_var=6), budget=100)
    assert len(res.archive) == 100 and res.metrics["feasible_ratio"] > 0
