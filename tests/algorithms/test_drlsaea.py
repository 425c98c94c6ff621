"""DRL-SAEA: the agent (targets, learning, exploration), state and reward by hand, the
granularity each action models, runs on the suites, seeds, bad input, config and CLI."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tmopt.algorithms.base import AlgorithmConfigError
from tmopt.algorithms.drlsaea import ACTIONS, DRLSAEA, DoubleDQN, elite_state, reward
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

from .contract import (
    algorithm_from_yaml,
    assert_seed_decides_the_archive,
    cli_metrics,
    drive_to_budget,
    run,
)
from .test_mgsaea import RBFDouble, TwoGroupProblem


def small(**kw) -> DRLSAEA:
    return DRLSAEA(**{"n_init": 20, "wmax": 3, "surrogate": RBFDouble, "replay_every": 2,
                      "copy_every": 3, "batch_size": 4, "train_epochs": 20, **kw})


def _agent(**kw) -> DoubleDQN:
    args = {"hidden": (5, 5), "buffer_size": 10, "discount": 0.9, "train_epochs": 300,
            "learning_rate": 0.02, "seed": 0, **kw}
    return DoubleDQN(4, 3, **args)


# ---- the agent -------------------------------------------------------------------------------
def test_double_dqn_target_takes_the_action_of_the_network_and_the_value_of_the_target():
    agent = _agent()
    with torch.no_grad():  # make the target network differ from the agent's
        for p in agent.target.parameters():
            p.add_(0.5)
    rng = np.random.default_rng(1)
    S, S1 = rng.random((3, 4)), rng.random((3, 4))
    A, R = np.array([0, 2, 1]), np.array([1.0, -0.5, 0.25])
    agent.store(S[0], 0, 0.0, S1[0])  # the scaling sees the same states in both paths
    got = agent.targets(S, A, R, S1).numpy()
    with torch.no_grad():
        q = agent.agent(agent._scaled(S)).numpy()
        q_next = agent.agent(agent._scaled(S1)).numpy()
        q_next_target = agent.target(agent._scaled(S1)).numpy()
    for i in range(3):
        want = q[i].copy()
        want[A[i]] = R[i] + 0.9 * q_next_target[i, np.argmax(q_next[i])]
        np.testing.assert_allclose(got[i], want)


def test_replay_learns_the_reward_of_a_terminal_like_transition():
    agent = _agent(discount=0.0)
    s0, s1 = np.array([0.0, 0, 0, 0]), np.array([1.0, 1, 1, 1])
    agent.store(s0, 1, 2.0, s1)
    agent.store(s1, 0, -1.0, s0)
    for _ in range(5):
        agent.replay(8)
    assert agent.q_values(s0)[1] == pytest.approx(2.0, abs=0.05)
    assert agent.q_values(s1)[0] == pytest.approx(-1.0, abs=0.05)


def test_the_greedy_action_is_taken_two_times_in_three():
    agent = _agent()
    state = np.array([0.3, 0.1, 0.7, 0.2])
    best = int(np.argmax(agent.q_values(state)))
    rng = np.random.default_rng(0)
    picks = np.array([agent.act(state, rng) for _ in range(3000)])
    assert np.mean(picks == best) == pytest.approx(2 / 3, abs=0.03)
    assert set(picks) == {0, 1, 2}


def test_the_replay_buffer_is_a_ring():
    agent = _agent(buffer_size=3)
    for k in range(5):
        agent.store(np.full(4, k), k % 3, float(k), np.full(4, k + 1))
    assert sorted(agent.R.tolist()) == [2.0, 3.0, 4.0]


# ---- state and reward by hand ----------------------------------------------------------------
def test_state_is_variance_sum_objective_sum_violation_and_budget_share():
    F = np.array([[1.0, 2.0], [3.0, 6.0]])
    G = np.array([[0.5, -1.0], [2.0, 0.0]])
    np.testing.assert_allclose(elite_state(F, G, 0.25), [2.0 + 8.0, 12.0, 2.5, 0.25])


def test_reward_is_relative_hypervolume_gain_plus_relative_violation_drop():
    feasible = np.array([[-1.0]])
    # HV normalised by lower 0 and upper (1, 1), reference 1.1: 0.1^2 before, 1.1^2 after
    assert reward(np.array([[1.0, 1.0]]), feasible, np.array([[0.0, 0.0]]), feasible) == \
        pytest.approx((1.21 - 0.01) / 0.01)
    # nothing feasible: only the violation part, (2 - 1) / 2
    assert reward(np.array([[1.0, 1.0]]), np.array([[2.0]]), np.array([[1.0, 1.0]]),
                  np.array([[1.0]])) == pytest.approx(0.5)
    # the feasible design lost (HV 0.01 -> 0: -1) and violation up from 1 to 3 (-2)
    assert reward(np.array([[1.0, 1.0], [2.0, 2.0]]), np.array([[1.0], [0.0]]),
                  np.array([[1.0, 1.0]]), np.array([[3.0]])) == pytest.approx(-3.0)


# ---- the algorithm ---------------------------------------------------------------------------
@pytest.mark.parametrize("action, outputs", [(0, 3), (1, None), (2, 2)])
def test_each_action_models_its_granularity(action, outputs):
    alg = small()
    alg.setup(TwoGroupProblem(), budget=100, seed=0)
    alg.tell(_batch(alg, alg.ask()))
    alg.action = action
    plan = alg._make_plan()
    assert plan.granularity == ACTIONS[action]
    if outputs is not None:
        assert 2 + plan.n_outputs_extra == outputs
    else:  # fine: one model per constraint some member violates
        violated = int((alg._pop.G.max(axis=0) > 0).sum())
        assert plan.n_outputs_extra == violated


def _batch(alg, X):
    from tmopt.evaluation.evaluator import Evaluator

    return Evaluator(alg.problem, len(X)).evaluate(X)


def test_runs_learn_and_report_their_actions():
    alg = small()
    res = run(alg, TwoGroupProblem(), budget=20 + 12 * 5)
    summary = res.metrics["algorithm_summary"]
    assert summary["iterations"] == 12 and sum(summary["actions"].values()) == 12
    assert summary["replays"] == 11 // 2  # 11 transitions observed, one replay per 2
    assert len(alg.agent.S) == 11


@pytest.mark.parametrize("name", sorted(SUITE_PROBLEMS))
def test_runs_on_every_suite_problem(name):
    problem = PymooBenchmark(name)
    n = problem.n_var + 2
    drive_to_budget(small(n_init=n), problem, n + 15)


def test_same_seed_same_archive():
    assert_seed_decides_the_archive(lambda: small(), PymooBenchmark("mw3", n_var=6), 60)


@pytest.mark.parametrize("kwargs, text", [
    ({"hidden": [5, 0]}, "hidden must be a list of integers >= 1"),
    ({"discount": 1.5}, r"discount must be a finite number in \[0.0, 1.0\], got 1.5"),
    ({"replay_every": 0}, "replay_every must be an integer >= 1, got 0"),
    ({"learning_rate": 0.0}, r"learning_rate must be a finite number in \(0.0, inf\)"),
    ({"wmax": -1}, "wmax must be an integer >= 0, got -1"),
])
def test_bad_arguments_are_named(kwargs, text):
    with pytest.raises(AlgorithmConfigError, match="drlsaea: " + text):
        DRLSAEA(**kwargs)


def test_yaml_matches_the_constructor():
    algorithm_from_yaml("drlsaea")


def test_cli_run(tmp_path):
    metrics = cli_metrics(tmp_path, "problem=mw1", "problem.n_var=4", "algorithm=drlsaea",
                          "surrogate=gp", "budget=53", "algorithm.wmax=2")
    assert metrics["algorithm"] == "drlsaea" and metrics["n_evals"] == 53  # 43 + 2 x 5
    assert sum(metrics["algorithm_summary"]["actions"].values()) == 2


# ---- reference=platemo: each PlatEMO behaviour alone (docs/algorithms-frontier.md) ---------
def test_configured_scaling_is_fixed_by_five_uniform_draws_and_saturates():
    agent = _agent(configured=True, seed=3)
    rng = np.random.default_rng(3)
    draws = rng.random((5, 4))  # DDQN.m: configure(net, rand(4, 5), -rand(3, 5))
    targets = -rng.random((5, 3))
    lo, hi = draws.min(axis=0), draws.max(axis=0)
    s = np.array([[300.0, 500.0, 2.0, 0.5]])
    np.testing.assert_allclose(agent._scaled(s).numpy(), 2 * (s - lo) / (hi - lo) - 1)
    np.testing.assert_array_equal(agent.out_lo, targets.min(axis=0))
    np.testing.assert_array_equal(agent.out_hi, targets.max(axis=0))
    with torch.no_grad():  # the network's [-1, 1] output read in the configured range
        raw = agent.agent(agent._scaled(s))[0].numpy()
    np.testing.assert_allclose(agent.q_values(s[0]),
                               targets.min(axis=0) + (raw + 1) * np.ptp(targets, axis=0) / 2)
    # raw sums in the hundreds saturate every tanh unit: two very different states get
    # the same Q-values; the buffer's min-max scaling tells them apart
    other = np.array([[600.0, 900.0, 4.0, 0.5]])
    q1, q2 = agent.q_values(s[0]), agent.q_values(other[0])
    np.testing.assert_allclose(q1, q2, atol=1e-9)
    buffered = _agent(seed=3)
    buffered.store(s[0], 0, 0.0, other[0])
    assert np.abs(buffered.q_values(s[0]) - buffered.q_values(other[0])).max() > 1e-3


def test_same_budget_share_gives_both_states_the_current_share():
    for same in (False, True):
        alg = small(same_budget_share=same)
        run(alg, TwoGroupProblem(), budget=20 + 6 * 5)
        S, S1 = alg.agent.S, alg.agent.S1
        if same:  # GenerateSample.m: Problem.FE / Problem.maxFE for both
            np.testing.assert_array_equal(S[:, 3], S1[:, 3])
        else:
            np.testing.assert_allclose(S1[:, 3] - S[:, 3], 5 / 50)
        np.testing.assert_array_equal(S[1:, :3], S1[:-1, :3])  # the states chain


def test_per_set_reward_uses_each_sets_lower_bound_and_nan_for_no_feasible():
    ok = np.array([[-1.0]])
    F0, F1 = np.array([[-1.0, 1.0]]), np.array([[0.0, 0.0]])
    # shared: lower (-1, 0), upper (0, 1): HV 1.1*0.1 -> 0.1*1.1, no change
    assert reward(F0, ok, F1, ok) == pytest.approx(0.0)
    # per set (PlatEMO's HV): F0 lower (-1, 0): 1.1 x 0.1 = 0.11; F1 lower (0, 0) and
    # upper (0, 1): f1 range collapses (1e-12), 0 -> 0 < 1.1, so 1.1 x 1.1 = 1.21
    assert reward(F0, ok, F1, ok, per_set=True) == pytest.approx((1.21 - 0.11) / 0.11)
    # losing every feasible design: -1 in the shared form, NaN -> 0 in PlatEMO's
    bad = np.array([[1.0]])
    assert reward(F1, ok, F1, bad) == pytest.approx(-1.0 + 0.0)
    assert reward(F1, ok, F1, bad, per_set=True) == pytest.approx(0.0)


def test_reference_platemo_sets_the_agents_and_mgsaeas_settings():
    from tmopt.algorithms.drlsaea import PLATEMO_SETTINGS
    from tmopt.algorithms.mgsaea import PLATEMO_SETTINGS as MGSAEA_SETTINGS
    alg = small(reference="platemo")
    assert {k: getattr(alg, k) for k in PLATEMO_SETTINGS} == PLATEMO_SETTINGS
    assert {k: getattr(alg, k) for k in MGSAEA_SETTINGS} == MGSAEA_SETTINGS
    run(alg, TwoGroupProblem(), budget=20 + 4 * 5)
    assert alg.agent.input_scaling == "configured"
    with pytest.raises(AlgorithmConfigError, match="drlsaea: input_scaling must be one of "
                                                   "buffer, configured, got 'x'"):
        DRLSAEA(input_scaling="x")
