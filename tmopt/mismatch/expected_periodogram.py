"""The expected periodogram of a short, tapered, offset-fitted segment under a given PSD.

A periodogram bin of an m-sample segment is not the PSD at its frequency: it is the PSD
seen through the window's spectral kernel, and -- because every segment's offset is
fitted (``fit.nominal_equation_columns``) -- with the part that the offset takes out
removed.  For a long segment the difference is negligible; in a piece of ~100 samples the
fitted offset takes up to half of the lowest bin (docs/mismatch.md 9.23), and a Whittle
fit that reads such bins as the PSD pulls the estimate down there.  The
*debiased Whittle likelihood* (Sykulski, Olhede, Guillaumin, Lilly & Early, Biometrika
106, 251 (2019)) compares each bin with its expectation under the model instead; this
module computes that expectation, exactly, from the model's autocovariance:

    X_k = sum_t w_t e^{-i w_k t} (x_t - sum_s u_s x_s) / norm,
    E|X_k|^2 = [Q1_k - 2 Re(conj(W_k) Q2_k) + |W_k|^2 Q3] / norm^2,

with ``w`` the window, ``u`` the offset's weights (sum 1), ``W_k`` the window's transform,
``Q1_k = sum_tau c(tau) rho_w(tau) e^{-i w_k tau}`` (Sykulski et al. Eq. 6; ``rho_w`` the
window's autocorrelation), ``Q2_k`` the transform of ``w * (C u)`` and ``Q3 = u' C u``
(``C`` the segment's Toeplitz covariance).  Every sum is an FFT: O(m log m) a segment.
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

__all__ = ["autocovariance", "expected_periodogram", "offset_weights", "SegmentKernel", "OFFSETS"]

#: How a segment's offset is taken out before its periodogram: ``none``, ``mean`` (the
#: plain mean), ``tapered`` (the window-weighted mean) or ``gls`` (generalised least
#: squares under the model, as the fit's offset columns are fitted: the tapered segment
#: whitened by ``psd`` with its DC bin set to zero, ``NoiseModel._whitener``).  Which one
#: the fit's residual follows is measured, not assumed (docs/mismatch.md 9.23).
OFFSETS = ("none", "mean", "tapered", "gls")


def autocovariance(psd: np.ndarray) -> np.ndarray:
    """Autocovariance ``c(tau)`` (L,) of a PSD given on the rfft grid of an L-point
    circle (``psd`` (L//2 + 1,), per-sample variance units: white noise of variance s^2
    has psd = s^2): ``c(tau) = (1/L) sum_j S(nu_j) e^{2 pi i j tau / L}``.  Lags up to
    L/2 are free of wrap-around only as far as ``c`` has decayed there; choose L a few
    times the longest segment."""
    n = 2 * (psd.size - 1)
    return sfft.irfft(psd, n=n)


def offset_weights(window: np.ndarray, offset: str,
                   psd: np.ndarray | None = None) -> np.ndarray | None:  # fmt: skip
    """Weights ``u`` (m,) with the fitted offset ``c = sum_t u_t x_t`` (None for
    ``none``).  ``gls`` minimises ``sum_(k != 0) |X_k - c W_k|^2 / S_k`` over the full
    m-point spectrum (``psd`` (m//2 + 1,) on the segment's rfft grid), so ``u = w G / Z``
    with ``G_t = sum_(k != 0) conj(W_k) e^(-i w_k t) / S_k`` and ``Z = sum_(k != 0)
    |W_k|^2 / S_k``; it is unbiased for a constant (``sum u = 1``)."""
    return SegmentKernel(window).offset_weights(offset, psd)


def expected_periodogram(acov: np.ndarray, window: np.ndarray, offset: str = "mean",
                         psd: np.ndarray | None = None,
                         fit_window: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """``E|X_k|^2`` (m//2 + 1,) on the rfft grid of an m-sample segment, normalised as
    ``noise_model._periodograms`` normalises (by ``sum w^2``), so that it equals the PSD
    for white noise away from DC.

    ``acov`` (>= m,): the autocovariance at lags 0..m-1; ``window`` (m,); ``offset``: one
    of :data:`OFFSETS` (``psd``: the model on the segment's rfft grid, for ``gls``);
    ``fit_window``: the window under which the offset was fitted, when it is not the
    periodogram's (a transient gate multiplies the periodogram's window only)."""
    return SegmentKernel(window, fit_window).expected(acov, offset, psd)


class SegmentKernel:
    """What one segment's windows contribute to :func:`expected_periodogram`, computed
    once (the window's autocorrelation and transforms) and reused for every channel and
    every pass of a fit.  FFTs of the convolutions are padded to fast lengths: a
    2m-point transform of an m with a large prime factor took 40x longer."""

    def __init__(self, window: np.ndarray, fit_window: np.ndarray | None = None):
        w = np.asarray(window, float)
        if w.ndim != 1 or not np.any(w):
            raise ValueError("window must be a 1-D array, not zero everywhere")
        self.w = w
        self.m = m = w.size
        self.fit_w = w if fit_window is None else np.asarray(fit_window, float)
        if self.fit_w.shape != w.shape:
            raise ValueError(f"fit_window must have the window's {m} samples")
        self.pad = sfft.next_fast_len(2 * m, real=True)
        wf = sfft.rfft(w, self.pad)
        self.rho = sfft.irfft(np.abs(wf) ** 2, self.pad)[:m]  # sum_t w_t w_(t+tau)
        self.wk = sfft.rfft(w)  # W_k on the segment's grid
        self.fit_wk = self.wk if fit_window is None else sfft.rfft(self.fit_w)
        self.norm = float(np.sum(w**2))

    def offset_weights(self, offset: str, psd: np.ndarray | None = None) -> np.ndarray | None:
        """See :func:`offset_weights` (for the fit's window)."""
        w, m = self.fit_w, self.m
        if offset not in OFFSETS:
            raise ValueError(f"offset must be one of {OFFSETS}; got {offset!r}")
        if offset == "none":
            return None
        if offset == "mean":
            return np.full(m, 1.0 / m)
        if offset == "tapered":
            return w / float(w.sum())
        if psd is None or np.size(psd) != m // 2 + 1:
            raise ValueError(f"offset 'gls' needs psd on the segment's rfft grid "
                             f"({m // 2 + 1} bins)")  # fmt: skip
        ratio = self.fit_wk / np.maximum(psd, 1e-300)
        ratio[0] = 0.0
        g = sfft.irfft(ratio, m) * m  # sum over the full spectrum, Hermitian halves
        weight = np.real(np.conj(self.fit_wk) * ratio)  # |W_k|^2 / S_k, 0 at DC
        z = float(2 * np.sum(weight) - (weight[-1] if m % 2 == 0 else 0.0))
        return w * g / z

    def _toeplitz_times(self, acov: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``C u`` for the m x m Toeplitz covariance ``C_ts = c(t - s)`` (circulant
        embedding of the padded length)."""
        m, n = self.m, self.pad
        col = np.zeros(n)
        col[:m] = acov[:m]
        col[n - m + 1:] = acov[1:m][::-1]
        return sfft.irfft(sfft.rfft(col) * sfft.rfft(u, n), n)[:m]

    def expected(self, acov: np.ndarray, offset: str = "mean",
                 psd: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
        """See :func:`expected_periodogram`."""
        m = self.m
        if acov.size < m:
            raise ValueError(f"acov must hold at least the segment's {m} lags; got {acov.size}")
        u = self.offset_weights(offset, psd)
        c = np.asarray(acov[:m], float)
        h = c * self.rho
        q = h.copy()
        q[1:] += h[1:][::-1]  # lag tau and lag -(m - tau) meet on the m-point circle
        out = np.real(sfft.rfft(q))
        if u is not None:
            cu = self._toeplitz_times(c, u)
            q2 = sfft.rfft(self.w * cu)
            out = out - 2 * np.real(np.conj(self.wk) * q2) + np.abs(self.wk) ** 2 * float(u @ cu)
        return np.maximum(out, 0.0) / self.norm
