"""The physical floor (tmopt.physics.floor): a bound no admissible motion beats, nearly
attained, and checked against the simulator over many noise seeds."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tmopt.physics import objectives as po
from tmopt.physics.floor import near_optimal_motion, stiffness_floor
from tmopt.physics.information import equation_noise_sigma, noise_free, predict
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
