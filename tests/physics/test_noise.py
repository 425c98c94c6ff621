"""Noise statistics (Table 1) and reproducibility."""

import numpy as np

from tmopt.physics.excitation import MultiSine
from tmopt.physics.noise import CHANNELS, noise_realisation, noise_sigmas, standard_normals
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
