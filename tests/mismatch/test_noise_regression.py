"""The coupled cross-spectrum by sequential regression (``cross="regression"``, an
option; docs/mismatch.md 9.21): one red source seen by two channels with a fixed
transfer is removed from the whitened second channel where its power is, so a column
that carries the same source is not "found" in the noise.  The default band-median
coherence (``cross="coherence"``) is shown failing on the same data."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from tmopt.mismatch.noise_model import CROSS_KINDS, Layout, NoiseModel, band_edges

N = 20000
SEEDS = range(8)


def _shared_red(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Two rows: white noise plus one random-walk (1/f^2) source, seen 1 : 0.7, and the
    column ``[0, source]`` (the source in the second row only, as a measured acceleration
    carries the force noise it measured; foreign 180077)."""
    rng = np.random.default_rng(seed)
    s = 0.05 * np.cumsum(rng.standard_normal(N))
    s -= s.mean()
    w = rng.standard_normal((2, N))
    return np.vstack([s + w[0], 0.7 * s + w[1]]), np.vstack([np.zeros(N), s])


def _glr(model: NoiseModel, x: np.ndarray, col: np.ndarray) -> float:
    """Generalised likelihood ratio of one column under the model (true coefficient 0)."""
    wx, wc = model.whiten(x), model.whiten(col)
    return float(np.sum(wx * wc)) ** 2 / float(np.sum(wc * wc))


def _glrs(cross: str) -> np.ndarray:
    out = []
    for seed in SEEDS:
        x, col = _shared_red(seed)
        out.append(_glr(NoiseModel.estimate(x, Layout.whole(N), 1.0, cross=cross), x, col))
    return np.array(out)


def test_a_column_carrying_the_shared_red_source_is_not_found_in_the_noise():
    # Under the regression model each GLR is ~chi^2(1); their sum over 8 draws ~chi^2(8).
    total = float(np.sum(_glrs("regression")))
    assert total < stats.chi2.ppf(0.99, len(SEEDS)), total


def test_the_band_median_coherence_finds_it_there():
    """What the regression fixes: the lowest band's median coherence is below the
    lowest bins', the source leaks into the whitened second row (GLR 13-88 per draw)."""
    glr = _glrs("coherence")
    assert float(np.sum(glr)) > 5 * stats.chi2.ppf(0.99, len(SEEDS)), glr


def test_the_second_row_is_white_at_the_lowest_bins():
    low = []
    for seed in SEEDS:
        x, _ = _shared_red(seed)
        m = NoiseModel.estimate(x, Layout.whole(N), 1.0, cross="regression")
        w = m.whiten(x)[1, m.interior()]
        per = np.abs(np.fft.rfft(w)) ** 2 / w.size
        low.append(per[1:31].mean())
    # the mean of 8 x 30 unit exponentials: sd 0.065
    assert 0.8 < float(np.mean(low)) < 1.2, low


def test_the_transfer_is_the_sources_ratio_where_the_source_dominates():
    x, _ = _shared_red(0)
    m = NoiseModel.estimate(x, Layout.whole(N), 1.0, cross="regression")
    assert m.coh is None and m.transfer is not None
    assert abs(m.transfer[0, 1, 0] - 0.7) < 0.02, m.transfer[0, 1, 0]
    # the model's matrix is Hermitian positive definite and its diagonal is the
    # marginal spectrum: channel 1's PSD holds 0.49 of channel 0's red power
    f = np.array([2e-4, 1e-3, 0.1])
    s = m.matrix(f)
    np.testing.assert_allclose(s, np.conj(np.swapaxes(s, 1, 2)))
    assert np.all(np.linalg.eigvalsh(s) > 0)
    ratio = s[0, 1, 1].real / s[0, 0, 0].real
    assert 0.4 < ratio < 0.6, ratio


def test_independent_channels_get_a_transfer_at_noise_level_and_unit_whitening():
    """Channel 1 (sd 3) on channel 0 (sd 1), independent: each band's transfer, in units
    of the sd ratio, is complex normal of variance 1/n (n bins), so n |h|^2 averages 1."""
    scaled, var = [], []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        x = rng.standard_normal((2, N)) * np.array([[1.0], [3.0]])
        m = NoiseModel.estimate(x, Layout.whole(N), 1.0, cross="regression")
        n = np.array([hi - lo for lo, hi in band_edges(np.fft.rfftfreq(N)[1:], 32, 4)])
        scaled.append(np.mean(n * np.abs(m.transfer[:, 1, 0] / 3.0) ** 2))
        var.append(m.whiten(x)[:, m.interior()].var(axis=1))
    assert 0.5 < float(np.mean(scaled)) < 2.0, scaled  # 66 bands: sd of the mean ~0.12
    np.testing.assert_allclose(np.array(var), 1.0, atol=0.02)


def test_a_relayout_keeps_the_regression():
    x, _ = _shared_red(1)
    m = NoiseModel.estimate(x, Layout.whole(N), 1.0, cross="regression")
    r = m.relayout(Layout(((0, N // 2), (N // 2 + 10, N)), N))
    np.testing.assert_array_equal(r.transfer, m.transfer)


def test_an_unknown_cross_kind_is_refused_by_name():
    x, _ = _shared_red(2)
    with pytest.raises(ValueError, match=r"cross must be one of .*'banded'"):
        NoiseModel.estimate(x, Layout.whole(N), 1.0, cross="banded")
    assert CROSS_KINDS == ("regression", "coherence")
    assert NoiseModel.estimate(x, Layout.whole(N), 1.0).transfer is None  # the default
