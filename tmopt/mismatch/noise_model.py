"""Noise models of the residual groups: what "consistent with noise" means.

Two groups of residuals are fitted (see :mod:`tmopt.mismatch.fit`):

* the **equation** group, two f_B-free combinations of the per-axis equation errors of
  Eqs. 9-10 (white, with a 2x2 covariance, by construction of the simulator; spatial
  whitening by the Cholesky factor), optionally with an AR(p) model per whitened channel
  (``colored_noise``);
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
from statsmodels.tsa.stattools import acovf, levinson_durbin

__all__ = ["robust_cov", "SpatialNoise", "SpectralNoise", "band_psd", "ar_fits",
           "prediction_errors"]  # fmt: skip

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


def ar_fits(x: np.ndarray, max_order: int) -> list[np.ndarray]:
    """Yule-Walker AR(1..max_order) coefficients of ``x`` (Levinson-Durbin recursion on
    the biased autocovariance; statsmodels), all orders from one recursion."""
    acov = acovf(x - x.mean(), nlag=max_order, fft=True)
    *_, phi = levinson_durbin(acov, nlags=max_order, isacov=True)
    return [np.asarray(phi[:p, p], dtype=float) for p in range(1, max_order + 1)]


def prediction_errors(x: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """``e_n = x_n - sum_j phi_j x_{n-j}`` (first ``len(phi)`` samples left as they are)."""
    e = x.copy()
    for j, p in enumerate(phi, start=1):
        e[j:] -= p * x[:-j]
    return e


@dataclass
class SpatialNoise:
    """White Gaussian noise with covariance ``cov`` (C, C), optionally AR(p) per channel.

    The AR part (``ar[c]`` = coefficients ``phi_1..phi_p`` of channel c after spatial
    whitening) models coloured noise; whitening then applies the prediction-error filter
    ``e_n = w_n - sum_j phi_j w_{n-j}`` and drops the first ``order`` samples (conditional
    likelihood).  ``order`` is the largest AR order *allowed* in this analysis, so that
    models with and without AR are compared on the same samples.
    """

    cov: np.ndarray
    ar: list[np.ndarray] = field(default_factory=list)
    ar_var: list[float] = field(default_factory=list)
    order: int = 0

    @classmethod
    def estimate(cls, residual: np.ndarray, order: int = 0) -> SpatialNoise:
        return cls(robust_cov(residual), order=order)

    @property
    def n_params(self) -> int:
        c = self.cov.shape[0]
        return c * (c + 1) // 2 + sum(a.size for a in self.ar)

    def spatial(self, arr: np.ndarray) -> np.ndarray:
        chol = np.linalg.cholesky(self.cov)
        return np.linalg.solve(chol, arr)

    def whiten(self, arr: np.ndarray) -> np.ndarray:
        """(C, M) -> (C, M - order), unit-variance white when the model holds."""
        w = self.spatial(arr)
        if not self.ar:
            return w[:, self.order :]
        out = np.empty((w.shape[0], w.shape[1] - self.order))
        for c, (phi, var) in enumerate(zip(self.ar, self.ar_var)):
            out[c] = prediction_errors(w[c], phi)[self.order :] / math.sqrt(var)
        return out

    def with_ar(self, residual: np.ndarray, p: int) -> SpatialNoise:
        """The same spatial part with an AR(p) (Yule-Walker) fitted to each whitened channel;
        innovation variances from the prediction errors on the compared samples."""
        w = self.spatial(residual)
        ar, var = [], []
        for c in range(w.shape[0]):
            phi = ar_fits(w[c], p)[-1]
            ar.append(phi)
            var.append(float(np.mean(prediction_errors(w[c], phi)[self.order :] ** 2)))
        return SpatialNoise(self.cov, ar, var, self.order)

    def loglik(self, residual: np.ndarray) -> float:
        """Exact (conditional on the first ``order`` samples) Gaussian log-likelihood."""
        e = self.whiten(residual)
        m = e.shape[1]
        logdet = float(np.linalg.slogdet(self.cov)[1]) * m / 2.0
        logdet += sum(0.5 * m * math.log(v) for v in self.ar_var)
        return float(-0.5 * np.sum(e**2) - 0.5 * e.size * math.log(2 * math.pi) - logdet)

    def describe(self) -> dict:
        return {
            "kind": "white" if not self.ar else f"AR({self.ar[0].size})",
            "std": np.sqrt(np.diag(self.cov)).tolist(),
            "correlation": float(self.cov[0, 1] / math.sqrt(self.cov[0, 0] * self.cov[1, 1]))
            if self.cov.shape[0] > 1 else 0.0,
            "ar": [a.tolist() for a in self.ar],
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
