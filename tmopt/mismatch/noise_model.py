"""Noise models of the residual groups: what "consistent with noise" means.

Two groups of residuals are fitted (see :mod:`tmopt.mismatch.fit`):

* the **equation** group, two f_B-free combinations of the per-axis equation errors of
  Eqs. 9-10 (white, with a 2x2 covariance, by construction of the simulator; spatial
  whitening by the Cholesky factor), optionally with a white + power-law red spectrum per
  whitened channel (``colored_noise``);
* the **kinematic** group, the four second-difference consistency residuals between
  displacement readouts and measured accelerations (coloured by construction: the second
  difference of white readout noise is blue, the acceleration noise flat), whitened in the
  frequency domain by a robust smoothed periodogram (running median over log-spaced bands).

Levels are always *estimated from the data*, never taken from Table 1: a recording from
another simulator or the real instrument may have other noise.  Every model provides
``whiten`` (to unit-variance white noise when the model holds) and ``loglik``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["robust_cov", "SpatialNoise", "SpectralNoise", "band_psd", "fit_red", "red_shape",
           "RED_EXPONENTS"]  # fmt: skip

_MAD = 1.4826  # MAD -> standard deviation for Gaussian data


def _robust_var(v: np.ndarray) -> float:
    med = np.median(v)
    return float((_MAD * np.median(np.abs(v - med))) ** 2)


def robust_cov(residual: np.ndarray) -> np.ndarray:
    """Robust covariance of white noise from first differences (C, M) -> (C, C).

    ``diff(r)/sqrt(2)`` has the covariance of white ``r`` but ignores slow structure
    (drifts, low-frequency lines); MAD scales ignore transients (glitches).  Off-diagonal
    terms by the Gnanadesikan-Kettenring identity ``cov(a,b) = (var(a+b) - var(a-b))/4``.
    """
    d = np.diff(residual, axis=1) / math.sqrt(2.0)
    c = d.shape[0]
    cov = np.empty((c, c))
    for i in range(c):
        cov[i, i] = _robust_var(d[i])
        for j in range(i):
            cov[i, j] = cov[j, i] = 0.25 * (_robust_var(d[i] + d[j]) - _robust_var(d[i] - d[j]))
    floor = 1e-12 * max(float(np.trace(cov)), 1e-300)
    w, v = np.linalg.eigh(cov)
    return (v * np.maximum(w, floor)) @ v.T  # keep it positive definite


RED_EXPONENTS = np.arange(0.5, 4.01, 0.25)  # searched power-law exponents (Davies trials)


def red_shape(f: np.ndarray, knee: float, gamma: float) -> np.ndarray:
    """White plus power-law red noise, ``1 + (knee/f)^gamma`` (the f^-1..f^-4 tails of
    LISA Pathfinder's acceleration noise, Armano et al., PRL 116, 231101 (2016))."""
    return 1.0 + (knee / f) ** gamma


def _rfft_freqs(m: int) -> np.ndarray:
    """rfft frequencies in cycles per sample with the DC bin set to half the first bin."""
    f = np.fft.rfftfreq(m)
    f[0] = 0.5 * f[1]
    return f


def fit_red(w: np.ndarray) -> tuple[float, float, float, float]:
    """Whittle fit of ``level (1 + (knee/f)^gamma)`` to one unit-scale channel (M,).

    Returns ``(knee [cycles/sample], gamma, level, lr)`` with ``lr = 2 (LL_red - LL_white)``
    (both levels profiled; the mean, fitted by the bias terms, is excluded).
    """
    i = np.abs(np.fft.rfft(w - w.mean())) ** 2 / w.size
    f = _rfft_freqs(w.size)
    i, f = i[1:], f[1:]
    ll_white = -i.size * (math.log(np.mean(i)) + 1.0)
    best = (0.0, 1.0, float(np.mean(i)), 0.0)
    for gamma in RED_EXPONENTS:
        for knee in np.geomspace(f[0], 0.5, 60):
            shape = red_shape(f, knee, gamma)
            level = float(np.mean(i / shape))
            ll = -float(np.sum(np.log(level * shape))) - i.size
            if 2 * (ll - ll_white) > best[3]:
                best = (float(knee), float(gamma), level, 2 * (ll - ll_white))
    return best


@dataclass
class SpatialNoise:
    """Gaussian noise with covariance ``cov`` (C, C) between channels, white -- or, with
    ``red`` = [(knee, gamma, level)] per spatially whitened channel, coloured with the PSD
    ``level (1 + (knee/f)^gamma)`` (f in cycles/sample), whitened in the frequency domain.
    """

    cov: np.ndarray
    red: list[tuple[float, float, float]] = field(default_factory=list)
    order: int = 0  # samples dropped by whitening (none; kept for callers' alignment)

    @classmethod
    def estimate(cls, residual: np.ndarray) -> SpatialNoise:
        return cls(robust_cov(residual))

    @property
    def n_params(self) -> int:
        c = self.cov.shape[0]
        return c * (c + 1) // 2 + 3 * len(self.red)

    def spatial(self, arr: np.ndarray) -> np.ndarray:
        chol = np.linalg.cholesky(self.cov)
        return np.linalg.solve(chol, arr)

    def psd(self, m: int) -> np.ndarray:
        """(C, m//2 + 1) PSD of the spatially whitened channels on the rfft grid."""
        f = _rfft_freqs(m)
        return np.array([lv * red_shape(f, k, g) for k, g, lv in self.red])

    def whiten(self, arr: np.ndarray) -> np.ndarray:
        """(C, M) -> (C, M), unit-variance white when the model holds."""
        w = self.spatial(arr)
        if not self.red:
            return w
        x = np.fft.rfft(w, axis=1) / np.sqrt(self.psd(w.shape[1]))
        return np.fft.irfft(x, n=w.shape[1], axis=1)

    def with_red(self, residual: np.ndarray) -> SpatialNoise:
        """The same spatial part with the power-law red model fitted to each channel."""
        w = self.spatial(residual)
        return SpatialNoise(self.cov, [fit_red(c)[:3] for c in w])

    def loglik(self, residual: np.ndarray) -> float:
        """Gaussian (Whittle for the red part) log-likelihood, scale profiled."""
        e = self.whiten(residual)
        n, m = e.size, e.shape[1]
        ll = -0.5 * n * (math.log(float(np.sum(e**2)) / n) + 1 + math.log(2 * math.pi))
        ll -= m * float(np.linalg.slogdet(np.linalg.cholesky(self.cov))[1])
        if self.red:
            ll -= float(np.sum(np.log(self.psd(m))))  # both halves of the spectrum
        return ll

    def describe(self) -> dict:
        return {
            "kind": "white" if not self.red else "white + power-law red",
            "std": np.sqrt(np.diag(self.cov)).tolist(),
            "correlation": float(self.cov[0, 1] / math.sqrt(self.cov[0, 0] * self.cov[1, 1]))
            if self.cov.shape[0] > 1 else 0.0,
            "red": [{"knee_cycles_per_sample": k, "exponent": g, "level": lv}
                    for k, g, lv in self.red],
        }  # fmt: skip


def taper(m: int, fraction: float = 0.1) -> np.ndarray:
    """Tukey window: the blue noise of a second difference has large boundary terms that a
    rectangular window leaks into every low-frequency bin; a smooth taper removes them."""
    from scipy.signal.windows import tukey

    return tukey(m, fraction)


def band_psd(v: np.ndarray, min_bins: int = 8, bands_per_decade: int = 10) -> np.ndarray:
    """Robust smooth estimate of ``E|X_k|^2 / M`` on the rfft grid of ``v`` (M,).

    Median of the periodogram over log-spaced bands (>= ``min_bins`` bins each) divided by
    ln 2 (the median of a chi^2_2/2 variable), interpolated in log-log between band centres.
    The median ignores narrow lines (tones, harmonics), so an effect at the excitation
    frequencies is not absorbed into the noise floor.
    """
    x = np.fft.rfft(v)
    per = np.abs(x) ** 2 / v.size
    k = np.arange(per.size, dtype=float)
    edges = [1]
    while edges[-1] < per.size:
        nxt = max(edges[-1] + min_bins, int(edges[-1] * 10 ** (1 / bands_per_decade)))
        edges.append(min(nxt, per.size))
    if len(edges) > 2 and edges[-1] - edges[-2] < min_bins:
        edges.pop(-2)
    centres, levels = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        centres.append(math.log(0.5 * (a + b - 1)))
        levels.append(math.log(max(np.median(per[a:b]) / math.log(2.0), 1e-300)))
    logk = np.log(np.maximum(k, 1.0))
    return np.exp(np.interp(logk, centres, levels))


@dataclass
class SpectralNoise:
    """Stationary Gaussian noise with a smooth PSD per channel (frequency-domain whitening).

    ``psd[c]`` is ``E|X_k|^2 / M`` on the rfft grid of length-M series; whitening divides
    the transform by its square root (Whittle approximation, circulant).
    """

    psd: np.ndarray  # (C, M//2 + 1)
    m: int
    window: np.ndarray

    @classmethod
    def estimate(cls, residual: np.ndarray) -> SpectralNoise:
        m = residual.shape[1]
        w = taper(m)
        norm = math.sqrt(float(np.mean(w**2)))  # PSD of the untapered series
        return cls(np.array([band_psd(r * w / norm) for r in residual]), m, w)

    @property
    def n_params(self) -> int:
        return 0  # a nuisance of the consistency check, identical in all compared models

    def whiten(self, arr: np.ndarray) -> np.ndarray:
        """Taper, then divide the transform by the PSD's square root (circulant Whittle):
        unit variance in the middle, the ends tapered to zero.  Zero rows (a regressor on
        one axis only) are skipped."""
        out = np.zeros(arr.shape)
        rows = np.flatnonzero(np.any(arr != 0, axis=1))
        if rows.size:
            x = np.fft.rfft(arr[rows] * self.window, axis=1) / np.sqrt(self.psd[rows])
            out[rows] = np.fft.irfft(x, n=self.m, axis=1)
        return out

    def loglik(self, residual: np.ndarray) -> float:
        """Whittle log-likelihood (up to the model-independent normalisation)."""
        e = self.whiten(residual)
        return float(-0.5 * np.sum(e**2) - 0.5 * np.sum(np.log(self.psd)) * 2.0)

    def describe(self) -> dict:
        return {"kind": "smoothed periodogram (per axis)"}
