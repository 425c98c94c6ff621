"""The stiffness-identification problem: schemes, bounds, constraints, failures, reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmopt.evaluation.evaluator import Evaluator
from tmopt.physics import objectives as phys_obj
from tmopt.physics.excitation import MultiSine
from tmopt.physics.simulator import SimulationConfig, simulate
from tmopt.problems.stiffness import StiffnessProblem

SHORT = {"duration": 120.0}
FIG6 = [5e-5, 2 * math.pi / 300, 0.0, 3e-5, 2 * math.pi / 500, 0.0]  # scheme B, k = 1


@pytest.mark.parametrize("scheme, n_var, n_obj, n_constr", [
    ("A", 3, 2, 2), ("B", 6, 2, 4), ("C", 6, 4, 4)])
@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_every_scheme_and_k_has_table2_dimensions_and_evaluates(scheme, n_var, n_obj,
                                                                n_constr, k):
    p = StiffnessProblem(scheme=scheme, n_freq=k, **SHORT)
    assert (p.n_var, p.n_obj, p.n_ieq_constr) == (n_var * k, n_obj, n_constr)
    assert len(p.variable_names()) == p.n_var
    X = p.xl + (p.xu - p.xl) * np.random.default_rng(k).random((3, p.n_var))
    out = p.evaluate(X, return_as_dictionary=True)
    assert out["F"].shape == (3, n_obj) and out["G"].shape == (3, n_constr)
    assert np.all(np.isfinite(out["F"])) and np.all(out["F"][:, 0] <= 120.0)


def test_constraint_groups_follow_the_test_masses_and_key_tm():
    p = StiffnessProblem(scheme="B", n_freq=2)
    assert [(g.name, g.indices, g.priority) for g in p.constraint_groups] == [
        ("TM1", (0, 1), 0), ("TM2", (2, 3), 1)]
    assert p.key_constraint_indices().tolist() == [0, 1]
    p2 = StiffnessProblem(scheme="B", n_freq=2, key_tm=2)
    assert p2.key_constraint_indices().tolist() == [2, 3]
    assert [g.name for g in StiffnessProblem(scheme="A").constraint_groups] == ["TM1"]


def test_variable_layout_and_bounds():
    p = StiffnessProblem(scheme="B", n_freq=2, amplitude_bounds=(1e-6, 1e-4),
                         period_bounds=(100.0, 1000.0))
    assert p.variable_names()[:6] == ["A1_TM1", "A2_TM1", "w1_TM1", "w2_TM1", "theta1_TM1",
                                      "theta2_TM1"]
    assert p.xl[0] == 1e-6 and p.xu[0] == 1e-4
    assert p.xl[2] == pytest.approx(2 * math.pi / 1000) and p.xu[2] == pytest.approx(
        2 * math.pi / 100)


def test_reference_constraints_are_eq20_on_the_reference_normalised_by_their_limits():
    p = StiffnessProblem(scheme="B", n_freq=1, constraints="reference", **SHORT)
    x = np.array([[4e-5, 0.02, 0.0, 1e-4, 0.01, 0.0]])
    g = p.constraints(x)[0]
    np.testing.assert_array_equal(g, p.reference_constraints(x)[0])
    assert g[0] == pytest.approx(4e-5 * 0.02**2 / (0.5 * 1e-7) - 1)
    assert g[2] == pytest.approx(1e-4 * 0.01**2 / (0.5 * 1e-7) - 1)
    # max |x_ref| of A sin(w t) over 120 s sampled at 10 Hz: the peak is reached
    assert g[1] == pytest.approx(4e-5 / (0.1 * 4e-3) - 1, rel=1e-6)


def test_constraints_are_eq20_on_the_simulated_motion_and_force():
    """Default: the realised run; the start-up transient can take the TM past the reference
    and the command past the reference's sum A w^2."""
    x = np.array([[2e-4, 2 * math.pi / 800, 0.0, 1e-5, 2 * math.pi / 300, 0.0]])
    cfg = dict(scheme="B", n_freq=1, duration=300.0)
    p = StiffnessProblem(**cfg, ramp_in=0.0)
    assert p.constraint_mode == "realised"
    res = p.simulate_designs(x)
    g = p.constraints(x)[0]
    assert g[0] == pytest.approx(res.max_abs_command[0, 0] / (0.5 * 1e-7) - 1)
    assert g[1] == pytest.approx(res.max_abs_position[0, 0] / (0.1 * 4e-3) - 1)
    assert g[3] == pytest.approx(res.max_abs_position[0, 1] / (0.1 * 4e-3) - 1)
    ref = p.reference_constraints(x)[0]
    # this design is feasible on paper (A w^2 = 1.2e-8 < 5e-8; 0.2 mm < 0.4 mm) but its
    # abrupt start (1.6e-6 m/s) saturates the actuator (|u| = F_max) and overshoots
    assert ref[0] < 0 and g[0] == pytest.approx(1.0) and g[1] > ref[1]
    assert np.array_equal(p.evaluate(x, return_as_dictionary=True)["G"][0], g)
    # the ramp-in (default 90 s) removes the overshoot and eases the start-up force
    ramped = StiffnessProblem(**cfg).constraints(x)[0]
    assert ramped[1] == pytest.approx(ref[1], abs=1e-3) and ramped[0] < g[0]


def test_problem_options_reach_the_simulator_and_bad_ones_are_one_line():
    p = StiffnessProblem(scheme="C", rls_columns="all", y_axes="round1", jacobian="online",
                         ramp_in=30.0, **SHORT)  # fmt: skip
    cfg = p.config
    assert cfg.rls_columns == ("k1xx", "k2xx", "k1yy", "k2yy", "R") and cfg.ramp_in == 30.0
    assert cfg.fb_bias == (1e-10, 1e-10) and cfg.control.jacobian == "online"
    assert StiffnessProblem(**SHORT).config.rls_columns == ("k1xx", "k2xx", "R")
    with pytest.raises(ValueError, match="rls_columns must include k2xx"):
        StiffnessProblem(scheme="C", rls_columns=["k1xx", "R"])
    with pytest.raises(ValueError, match="problem stiffness: y_axes must be one of"):
        StiffnessProblem(y_axes="lisa")
    with pytest.raises(ValueError, match="constraints must be one of"):
        StiffnessProblem(constraints="none")


def test_scheme_a_holds_tm2_at_nominal():
    p = StiffnessProblem(scheme="A", n_freq=1, **SHORT)
    ref1, ref2 = p.references(np.array([[5e-5, 0.02, 0.3]]))
    assert np.all(ref2.evaluate(np.linspace(0, 120, 50)) == 0.0)
    assert ref1.evaluate(np.array([0.0]))[0, 0] == pytest.approx(0.0, abs=1e-20)


def test_objectives_equal_the_simulator_objectives():
    p = StiffnessProblem(scheme="C", n_freq=1, duration=300.0, noise_seed=3)
    F = p.evaluate(np.array([FIG6]), return_as_dictionary=True)["F"][0]
    cfg = SimulationConfig(duration=300.0, record="estimates")  # the same defaults
    res = simulate(MultiSine(5e-5, 2 * math.pi / 300), MultiSine(3e-5, 2 * math.pi / 500),
                   cfg, seed=3)
    for j, idx in enumerate((0, 1)):
        obj = phys_obj.evaluate(res, idx=idx)
        assert F[2 * j] == obj["convergence_time"][0]
        assert F[2 * j + 1] == obj["convergence_accuracy"][0]


def test_results_do_not_depend_on_the_chunk_size():
    X = np.array([FIG6, [1e-5, 0.03, 1.0, 2e-5, 0.01, 2.0], [8e-5, 0.01, 0.5, 1e-6, 0.05, 0.0]])
    fa, ga = StiffnessProblem(scheme="B", n_freq=1, chunk=1, **SHORT).evaluate(X)
    fb, gb = StiffnessProblem(scheme="B", n_freq=1, chunk=100, **SHORT).evaluate(X)
    assert np.array_equal(fa, fb) and np.array_equal(ga, gb)


def test_a_diverging_design_is_a_failure_with_the_simulators_reason():
    # 1e-2 s^-2 needs 1e-6 m s^-2 at 1e-4 m, ten times F_max: TM1 runs away
    p = StiffnessProblem(scheme="B", n_freq=1, duration=300.0, stiffness_1=(1e-2, 1e-7))
    ev = Evaluator(p, budget=10)
    batch = ev.evaluate(np.array([[1e-4, 2 * math.pi / 300, 0.0, 1e-5, 2 * math.pi / 300, 0.0],
                                  [1e-7, 2 * math.pi / 300, 0.0, 1e-5, 2 * math.pi / 300, 0.0]]))
    assert batch.failed.tolist() == [True, False]
    assert "bound" in batch.reason[0] and batch.reason[1] == ""
    assert np.all(np.isfinite(batch.F)) and batch.G[0].min() > 0  # infeasible to the optimiser


def test_identification_report_gives_table3_numbers():
    p = StiffnessProblem(scheme="B", n_freq=1, duration=600.0)
    rep = p.identification_report(np.array(FIG6))
    for key in ("final_accuracy_TM1", "M_TM1", "M_TM1@7e-11", "M_TM1@5e-11",
                "max_abs_x_TM1", "max_abs_force_TM2", "max_tracking_error_TM1"):
        assert np.isfinite(rep[key])
    assert rep["M_TM1"] == pytest.approx(rep["convergence_time_TM1"] / 60
                                         + 1e10 * rep["convergence_accuracy_TM1"])
    # a stricter threshold can only take longer to meet
    assert rep["convergence_time_TM1@5e-11"] >= rep["convergence_time_TM1@7e-11"] \
        >= rep["convergence_time_TM1"]


@pytest.mark.parametrize("kwargs, message", [
    ({"scheme": "D"}, "scheme must be one of"),
    ({"n_freq": 0}, "n_freq must be an integer in [1, 8]"),
    ({"key_tm": 3}, "key_tm must be an integer in [1, 2]"),
    ({"amplitude_bounds": (1e-4, 1e-6)}, "amplitude_bounds must be two finite numbers"),
    ({"amplitude_bounds": (-1e-6, 1e-4)}, "amplitude_bounds must be >= 0"),
    ({"period_bounds": (0.1, 100.0)}, "above the Nyquist period"),
    ({"epsilon": 0.0}, "epsilon must be a finite number > 0"),
    ({"duration": 0.01}, "duration"),
    ({"controller": "lqr"}, "controller must be one of"),
])
def test_bad_input_names_the_parameter(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        StiffnessProblem(**kwargs)
