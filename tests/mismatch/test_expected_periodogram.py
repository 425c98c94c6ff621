"""The exact expected periodogram of a tapered, offset-fitted segment, checked against a
Monte Carlo average of the same operations (an independent path) and an AR(1) process's
known autocovariance."""

import numpy as np
import pytest
from scipy.signal import lfilter

from tmopt.mismatch.expected_periodogram import (
    OFFSETS,
    autocovariance,
    expected_periodogram,
    offset_weights,
)
from tmopt.mismatch.noise_model import taper

PHI, M, DRAWS = 0.995, 200, 4000


def _ar1_psd(f):
    """AR(1) with unit innovations, per-sample units, f in cycles/sample."""
    return 1.0 / np.abs(1 - PHI * np.exp(-2j * np.pi * f)) ** 2


@pytest.fixture(scope="module")
def segments():
    rng = np.random.default_rng(7)
    burn = 3000  # the AR(1)'s memory is ~1/(1 - PHI) = 200 samples
    return lfilter([1.0], [1.0, -PHI], rng.standard_normal((DRAWS, M + burn)), axis=1)[:, burn:]


def test_autocovariance_of_a_psd_is_the_ar1_formula():
    n = 1 << 14
    acov = autocovariance(_ar1_psd(np.fft.rfftfreq(n)))
    lags = np.arange(300)
    np.testing.assert_allclose(acov[lags], PHI**lags / (1 - PHI**2), rtol=1e-6)


def test_gls_offset_weights_are_the_frequency_domain_least_squares(segments):
    w = taper(M)
    psd = _ar1_psd(np.fft.rfftfreq(M))
    u = offset_weights(w, "gls", psd)
    assert u.sum() == pytest.approx(1.0, abs=1e-12)  # a constant is fitted exactly
    xk, wk = np.fft.fft(segments * w, axis=1), np.fft.fft(w)
    s_full = np.concatenate([psd, psd[1:(M + 1) // 2][::-1]])
    direct = (np.real(np.sum((np.conj(wk) / s_full)[1:] * xk[:, 1:], axis=1))
              / np.sum(np.abs(wk[1:]) ** 2 / s_full[1:]))  # fmt: skip
    np.testing.assert_allclose(segments @ u, direct, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("offset", OFFSETS)
def test_expected_periodogram_is_the_monte_carlo_mean(segments, offset):
    w = taper(M)
    f = np.fft.rfftfreq(M)
    psd = _ar1_psd(f)
    u = offset_weights(w, offset, psd)
    x = segments if u is None else segments - (segments @ u)[:, None]
    measured = np.mean(np.abs(np.fft.rfft(x * w, axis=1)) ** 2, axis=0) / np.sum(w**2)
    expected = expected_periodogram(PHI ** np.arange(M) / (1 - PHI**2), w, offset, psd)
    # each bin's mean of DRAWS exponential-like values: relative error ~ 1/sqrt(DRAWS)
    ratio = measured[1:] / expected[1:]
    assert np.max(np.abs(ratio - 1)) < 5 / np.sqrt(DRAWS)
    if offset != "none":  # the offset takes out what a red spectrum puts at the lowest bin
        assert expected[1] < 0.9 * expected_periodogram(
            PHI ** np.arange(M) / (1 - PHI**2), w, "none")[1]  # fmt: skip


def test_white_noise_expects_its_level_away_from_dc():
    w = taper(512)
    acov = np.zeros(512)
    acov[0] = 3.0
    e = expected_periodogram(acov, w, "none")
    np.testing.assert_allclose(e, 3.0, rtol=1e-12)


def test_bad_arguments_are_named():
    w = taper(64)
    with pytest.raises(ValueError, match="offset must be one of"):
        expected_periodogram(np.ones(64), w, "median")
    with pytest.raises(ValueError, match="acov must hold"):
        expected_periodogram(np.ones(10), w)
    with pytest.raises(ValueError, match="needs psd"):
        expected_periodogram(np.ones(64), w, "gls")
