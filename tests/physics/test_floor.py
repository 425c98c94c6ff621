"""The physical floor (tmopt.physics.floor): a bound no admissible motion beats, nearly
attained, and checked against the simulator over many noise seeds."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tmopt.metrics.identification import metric_m_at_threshold
from tmopt.physics import objectives as po
from tmopt.physics.floor import (
    cycloid_transitions,
    knot_motion,
    near_optimal_motion,
    stiffness_floor,
)
from tmopt.physics.information import (
    covariance_trajectory,
    equation_noise_sigma,
    noise_free,
    predict,
)
from tmopt.physics.noise import heldout_seeds
from tmopt.physics.report import study_designs
from tmopt.physics.simulator import SimulationConfig, simulate

CFG = SimulationConfig()  # the paper's 1200 s at 10 Hz, Table 1, Eq. 20 limits
#: The near-optimal motion starts at rest by itself: simulated without the ramp-in.
RAW = replace(CFG, ramp_in=0.0)


def test_floor_numbers_follow_from_table1_and_eq20():
    fl = stiffness_floor(CFG, 0, "realised")
    # the square wave +-alpha2 D from t = 0, no force limit: sigma_e / (|K1| X sqrt(N))
    ideal = equation_noise_sigma(CFG) / (np.sqrt(3) / 4 * 4e-4 * np.sqrt(12000))
    assert ideal == pytest.approx(9.13e-11, rel=1e-3)
    assert ideal < fl.final < 1.06 * ideal  # starting at rest costs the first ~127 s
    assert fl.final_mean == pytest.approx(np.sqrt(2 / np.pi) * fl.final)
    assert fl.accel_max == pytest.approx(0.5e-7 + 1e-7 * 4e-4 + 1e-10)
    acc = fl.convergence_accuracy(np.array([50.0, 112.1, 600.0, 1199.9]))
    assert np.all(np.diff(acc) < 0) and acc[-1] == pytest.approx(fl.final, rel=1e-3)
    m, t0 = fl.m_floor()
    assert m == pytest.approx(t0 / 60 + 1e10 * fl.convergence_accuracy(t0, "mean"))
    grid = np.arange(0, 1200, 7.0)
    assert m <= np.min(grid / 60 + 1e10 * fl.convergence_accuracy(grid, "mean")) + 1e-12
    # the rate does not move it (per-sample sigmas scale with sqrt(fs))
    from tmopt.physics.scenario import config_at_rate

    at20 = stiffness_floor(config_at_rate(20.0), 0, "realised")
    assert at20.final == pytest.approx(fl.final, rel=2e-3)
    # without the force limit of Eq. 20 (reference mode: F_max) the floor is lower
    assert stiffness_floor(CFG, 0, "reference").final < fl.final


def test_no_admissible_motion_carries_more_information_than_the_envelope():
    """sum x_n^2 of realised motions (a priori feasible designs and the near-optimal
    motion) never exceeds the envelope's at any n."""
    fl = stiffness_floor(CFG, 0, "realised")
    bound = np.cumsum(fl.envelope() ** 2)
    r1, r2 = study_designs(20)
    res = simulate(r1, r2, replace(CFG, record="full"))
    x = near_optimal_motion(fl)
    near = simulate(x[None], np.zeros((1, x.size)), replace(RAW, record="full"))
    assert np.all(po.eq20_realised(near)[0] <= 0)  # admissible: Eq. 20 on the realised run
    ok = (po.eq20_realised(res)[:, :2] <= 0).all(axis=1)  # TM1 keeps Eq. 20
    assert ok.sum() >= 5
    for motion in [*res.x1_true[ok], near.x1_true[0]]:
        assert np.all(np.cumsum(motion**2) <= bound * (1 + 1e-12))


def test_simulator_over_seeds_lands_on_the_near_optimal_motions_bound_above_the_floor():
    """Monte Carlo, an independent path: 96 seeds of the simulator on the near-optimal
    admissible motion.  The rms final error matches that motion's own Cramer-Rao bound
    (within 3 standard errors of an rms estimate, 1/sqrt(2S)) and that bound lies within
    15 % above the floor."""
    fl = stiffness_floor(CFG, 0, "realised")
    x = near_optimal_motion(fl)
    sigma = equation_noise_sigma(CFG)
    free = simulate(x[None], np.zeros((1, x.size)), replace(noise_free(RAW), record="full"))
    own = predict(free, sigma)["final_sd"][0]
    assert fl.final <= own < 1.15 * fl.final
    s = 96
    res = simulate(np.tile(x, (s, 1)), np.zeros((s, x.size)), RAW, seed=heldout_seeds(s))
    assert np.all(po.eq20_realised(res) <= 0)
    err = res.theta_hat[:, -1, 0] - CFG.theta_true[0]
    rms = np.sqrt(np.mean(err**2))
    assert abs(rms / own - 1) < 3 / np.sqrt(2 * s)
    assert rms > fl.final * (1 - 3 / np.sqrt(2 * s))


@pytest.mark.parametrize("kwargs, message", [
    ({"idx": 2}, "idx must be 0"), ({"constraints": "both"}, "constraints must be")])
def test_bad_input_is_one_line(kwargs, message):
    with pytest.raises(ValueError, match=message):
        stiffness_floor(CFG, **{"idx": 0, "constraints": "realised", **kwargs})
    with pytest.raises(ValueError, match="statistic must be"):
        stiffness_floor(CFG, 0, "realised").convergence_accuracy(100.0, "median")
    with pytest.raises(ValueError, match="needs noise"):
        stiffness_floor(noise_free(CFG), 0, "realised")


# ---- motion families and Eq. 18's step law (issue 18: how far below 5.99 can M go) -------

FL = stiffness_floor(CFG, 0, "realised")
T = np.arange(FL.n_steps) / FL.sample_rate


def _accel(x: np.ndarray) -> np.ndarray:
    return np.diff(x, 2) * FL.sample_rate**2


def test_cycloid_transitions_start_at_rest_reach_their_levels_and_keep_the_limits():
    """Analytic cycloid: peak acceleration 2 pi |h| / tau^2 = margin x the force limit,
    duration tau = sqrt(2 pi |h| / a); levels held between transitions."""
    x_max = FL.x_max * (1 - 1e-4)
    x = cycloid_transitions(FL, [x_max, -x_max], [10.0, 50.0], margin=0.9)
    a = 0.9 * FL.force_limit
    rise, cross = np.sqrt(2 * np.pi * x_max / a), np.sqrt(4 * np.pi * x_max / a)
    assert np.all(x[T <= 10.0] == 0.0)
    hold = (T >= 10.0 + rise) & (T <= 10.0 + rise + 50.0)
    assert np.allclose(x[hold], x_max, rtol=0, atol=1e-15)
    assert np.allclose(x[T >= 60.0 + rise + cross], -x_max, rtol=0, atol=1e-15)
    assert np.max(np.abs(x)) <= FL.x_max
    assert np.max(np.abs(_accel(x))) == pytest.approx(a, rel=1e-3)
    # overlapping transitions add their accelerations: still bounded by twice the peak
    over = cycloid_transitions(FL, [x_max, -x_max], [0.0, -100.0], margin=0.5)
    assert np.max(np.abs(_accel(over))) <= FL.force_limit * (1 + 1e-3)
    # near_optimal_motion is the two-transition member (one home for the shape)
    ts = 400.0
    near = near_optimal_motion(FL, 0.8, ts)
    r = np.sqrt(2 * np.pi * x_max / (0.8 * FL.force_limit))
    assert np.array_equal(near, cycloid_transitions(FL, [x_max, -x_max], [0.0, ts - r], 0.8))


def test_knot_motion_is_the_double_integral_of_its_acceleration():
    """One knot at 100 s, held after: a = A F t / 100 then A F, so x = A F t^3 / 600 up to
    100 s (the trapezoids' error is O(dt^2))."""
    x = knot_motion(FL, [0.5], [100.0])
    early = T <= 100.0
    exact = 0.5 * FL.force_limit * T[early] ** 3 / 600.0
    assert np.allclose(x[early], exact, rtol=1e-3, atol=1e-12)
    assert np.max(np.abs(_accel(x))) == pytest.approx(0.5 * FL.force_limit, rel=1e-3)
    with pytest.raises(ValueError, match="knots must be increasing"):
        knot_motion(FL, [0.1, 0.2], [100.0, 50.0])


def test_motion_information_is_the_rls_covariance_of_the_simulated_run():
    """Independent path: the closed loop's own RLS covariance (three identified columns:
    k1xx, k2xx of the resting TM2, R) on the simulated noise-free run against the tracked
    reference's information with R fitted; without R it is the floor's sum, larger."""
    x = near_optimal_motion(FL, 0.9, 300.0)
    free = simulate(x[None], np.zeros((1, x.size)), replace(noise_free(RAW), record="full"))
    sim_var = equation_noise_sigma(RAW) ** 2 * covariance_trajectory(free)[0, :, 0]
    info = FL.motion_information(x)[0]
    late = T >= 60.0
    assert np.allclose(1 / info[late], sim_var[late], rtol=0.01)
    plain = FL.motion_information(x, intercept=False)[0]
    assert np.all(plain >= info)
    at = int(250 * FL.sample_rate)  # end of the rise: x far from 0 but close to its mean
    assert plain[at] > 2 * info[at]
    # with R fitted the information is K^2 sum (x - mean x)^2 / sigma_e^2 (prior aside)
    assert info[-1] - FL.prior_info == pytest.approx(
        (FL.coefficient / FL.sigma_e) ** 2 * np.sum((x - x.mean()) ** 2), rel=1e-6)


def test_expected_scores_match_the_simulators_prediction_and_monte_carlo():
    """The tracked-motion expectations equal predict() on the simulated noise-free run
    (its bias is negligible), and a Monte Carlo of unbiased least-squares error paths
    (a Gaussian martingale with Var = 1/info) scored by Eqs. 18-19 (metric_m_at_threshold)
    lands on them within the gamma law's few per cent."""
    x = near_optimal_motion(FL)
    free = simulate(x[None], np.zeros((1, x.size)), replace(noise_free(RAW), record="full"))
    pred = predict(free, equation_noise_sigma(RAW))
    mine = FL.expected_scores(FL.motion_information(x))
    for q in ("convergence_time", "convergence_accuracy", "M"):
        assert mine[q][0] == pytest.approx(pred[q][0], rel=0.01)
    var = 1 / FL.motion_information(x)[0]
    rng = np.random.default_rng(5)
    s = 400
    inc = rng.standard_normal((s, var.size)) * np.sqrt(np.diff(var[::-1], prepend=0.0))
    err = np.cumsum(inc, axis=1)[:, ::-1]  # err_N ~ N(0, v_N), err_{n-1} - err_n independent
    truth = float(CFG.theta_true[0])
    mc = metric_m_at_threshold(truth + err, truth, 1e-10, FL.sample_rate, theta0=truth + 1.0)
    t_se = mc["convergence_time"].std(ddof=1) / np.sqrt(s)
    assert abs(mc["convergence_time"].mean() - mine["convergence_time"][0]) < 4 * t_se
    assert mine["convergence_accuracy"][0] == pytest.approx(
        mc["convergence_accuracy"].mean(), rel=0.06)


def test_step_law_estimate_lies_between_the_free_floor_and_an_admissible_motion():
    """Eq. 18's step law on the envelope: above the floor's free-t0 M (it no longer picks
    t0), below the near-optimal admissible motion (more information at every sample)."""
    est = FL.step_law_m()
    assert FL.m_floor()[0] < est["M"]
    near = FL.expected_scores(FL.motion_information(near_optimal_motion(FL)))
    assert est["M"] < near["M"][0]
    assert est["convergence_time"] < near["convergence_time"][0]


def test_intercept_bound_holds_for_realised_motions_and_constant_acceleration_attains_it():
    """With R fitted, the information of realised admissible motions (20 a priori feasible
    multi-sines that keep Eq. 20, the near-optimal motion) never exceeds the proven bound;
    the constant acceleration from rest attains it until it reaches x_max, at 4/9 of the
    envelope's (1/45 against 1/20); late in the run it is the envelope's."""
    bound = FL.intercept_bound()
    envelope = FL.motion_information(FL.envelope(), intercept=False)[0]
    assert np.all(bound <= envelope)
    early = (T > 30.0) & (T < 120.0)  # (sums over samples: 1/n from the integrals)
    assert np.allclose(bound[early] / envelope[early], 4 / 9, rtol=5e-3)
    assert bound[-1] == envelope[-1]
    parabola = 0.5 * FL.accel_max * T**2
    assert np.allclose(FL.motion_information(parabola)[0][early], bound[early], rtol=1e-6)
    r1, r2 = study_designs(20)
    res = simulate(r1, r2, replace(noise_free(CFG), record="full"))
    x = near_optimal_motion(FL, 0.97, 200.0)
    near = simulate(x[None], np.zeros((1, x.size)), replace(noise_free(RAW), record="full"))
    ok = (po.eq20_realised(res)[:, :2] <= 0).all(axis=1)
    assert ok.sum() >= 5 and np.all(po.eq20_realised(near)[0] <= 0)
    motions = np.vstack([res.x1_true[ok], near.x1_true])
    assert np.all(FL.motion_information(motions) <= bound * (1 + 1e-9))


def test_bang_bang_transitions_are_the_fastest_at_their_acceleration():
    """shape="bang": +-a then rest, duration 2 sqrt(h / a) (against sqrt(2 pi h / a) for the
    cycloid of the same peak); the margin may reach accel_max / force_limit, not more."""
    h = FL.x_max * (1 - 1e-4)
    x = cycloid_transitions(FL, [h], [0.0], margin=1.0, shape="bang")
    tau = 2 * np.sqrt(h / FL.force_limit)
    assert np.all(x[T >= tau] == pytest.approx(h, abs=1e-15))
    assert np.max(x[T < tau - 1.0]) < h
    assert np.max(np.abs(_accel(x))) == pytest.approx(FL.force_limit, rel=1e-3)
    top = FL.accel_max / FL.force_limit
    cycloid_transitions(FL, [h], [0.0], margin=top, shape="bang")
    with pytest.raises(ValueError, match="margin must be in"):
        cycloid_transitions(FL, [h], [0.0], margin=1.01 * top)
    with pytest.raises(ValueError, match="shape must be"):
        cycloid_transitions(FL, [h], [0.0], shape="square")
