"""Noise statistics (Table 1) and reproducibility."""

import numpy as np
import pytest

from tmopt.physics.excitation import MultiSine
from tmopt.physics.noise import (
    CHANNELS,
    FRESH_SEEDS,
    HELDOUT_SEEDS,
    USER_SEEDS,
    check_heldout,
    fresh_seeds,
    heldout_seeds,
    noise_realisation,
    noise_sigmas,
    standard_normals,
)
from tmopt.physics.simulator import SimulationConfig, simulate


def _check_white_gaussian(x, sigma):
    """Sample std within 5 standard errors (se of s/sigma is 1/sqrt(2N)); mean likewise."""
    n = x.size
    assert abs(x.std() / sigma - 1) < 5 / np.sqrt(2 * n)
    assert abs(x.mean()) < 5 * sigma / np.sqrt(n)
    # whiteness: lag-1 autocorrelation within 5/sqrt(N) of zero
    assert abs(np.corrcoef(x[:-1], x[1:])[0, 1]) < 5 / np.sqrt(n)


def test_realisation_statistics_match_table_1():
    sig = noise_sigmas(1e-11, 1e-8, 1e-12, 1e-12, 1e-10)
    noise = noise_realisation(3, 12000, sig)
    assert noise.shape == (len(CHANNELS), 12000)
    for row, s in zip(noise, sig):
        _check_white_gaussian(row, s)


def test_same_seed_same_numbers_different_seed_different():
    a, b, c = standard_normals(7, 100), standard_normals(7, 100), standard_normals(8, 100)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)


def test_closed_loop_measurement_noise_statistics():
    cfg = SimulationConfig(duration=600.0)
    res = simulate(MultiSine(1e-5, 2 * np.pi / 300), MultiSine(1e-5, 2 * np.pi / 500), cfg)
    _check_white_gaussian((res.x1 - res.x1_true)[0], cfg.sigma_m1)
    _check_white_gaussian((res.y2 - res.y2_true)[0], cfg.sigma_m2)


def test_seed_spaces_are_disjoint_and_float64_exact():
    """Held-out seeds can never be drawn by a search: the ranges do not meet, and every
    seed survives float64 (pymoo's outputs, JSON) exactly."""
    spaces = sorted([USER_SEEDS, FRESH_SEEDS, HELDOUT_SEEDS])
    assert all(a[1] <= b[0] for a, b in zip(spaces, spaces[1:]))
    assert spaces[-1][1] <= 2**53
    fresh = fresh_seeds(0, 0, np.arange(2000))
    assert fresh.min() >= FRESH_SEEDS[0] and fresh.max() < FRESH_SEEDS[1]
    held = heldout_seeds(32)
    assert held[0] == HELDOUT_SEEDS[0] and held[-1] == HELDOUT_SEEDS[0] + 31
    assert np.array_equal(held.astype(np.float64).astype(np.int64), held)


def test_fresh_seeds_are_a_deterministic_function_of_noise_seed_run_seed_and_row():
    a = fresh_seeds(3, 1, np.arange(50))
    assert np.array_equal(a, fresh_seeds(3, 1, np.arange(50)))  # replay: same draws
    assert np.array_equal(a[10:20], fresh_seeds(3, 1, np.arange(10, 20)))  # per row
    assert len(set(a.tolist())) == 50  # a new realisation per evaluation
    assert not set(a.tolist()) & set(fresh_seeds(3, 2, np.arange(50)).tolist())
    assert not set(a.tolist()) & set(fresh_seeds(4, 1, np.arange(50)).tolist())


def test_check_heldout_refuses_seeds_a_search_used():
    held = heldout_seeds(4)
    check_heldout(held, np.array([[0, 1], [-1, -1]]))
    with pytest.raises(ValueError, match="also scored the search"):
        check_heldout(held, np.array([5, int(held[2])]))
    with pytest.raises(ValueError, match="held-out seeds must lie in"):
        check_heldout(np.array([3]), np.zeros(0))
    with pytest.raises(ValueError, match="number of held-out seeds must be an integer"):
        heldout_seeds(-1)
