"""The readout noise of each position, so that the stiffness acts on the true position.

Eqs. 1-2 put the stiffness on the test mass's true position ``r``; the equation group
(Eq. 10) can only regress on the readout ``x = r + n_r``.  The difference leaves
``-k n_r`` in the equation residual.  Its size is small (k ~ 1e-6 s^-2 times n_r), but it
is *correlated with the commanded force*: the controller drives the force from the same
readout noise (at high frequency, on an axis without excitation, the force is almost all
its response to ``n_r``).  A force-shaped candidate -- an actuation gain ``g f``, an
``f|f|`` term -- then finds ``g ~ k / G(f)`` with ``G`` the loop's gain from readout to
force: on clean recordings with LPF-like stiffness it reached GLR 16-31 on an unexcited y
axis, rising with k (k scaled by 0, 1, 2: GLR 5.5, 16.0, 31.5; docs/mismatch.md 9.19),
and named an actuation gain where there is none.

The readout and the accelerometer see the same motion, so their difference is the
readout's own error: double-integrating the exact ZOH kinematic residual
(:func:`tmopt.mismatch.fit.kinematic_target`, docs 9.4) gives ``d = n_r - (double
integral of the accelerometer's error)`` plus a straight line per segment.  The second
term is red (its PSD falls as f^-4), the first flat or 1/f-cornered, so ``d``'s spectrum
has a high-frequency plateau where ``d ~ n_r``.  The estimate is ``d`` weighted by the
Wiener gain ``H(f) = P / S_d(f)`` (clipped to [0, 1]), with ``P`` the plateau and
``S_d`` ``d``'s smoothed periodogram (median over log-spaced bands, robust to lines): the
complementary filter of readout and accelerometer (Wiener 1949; the LPF's position
reconstruction combines the two sensors the same way, Armano et al., PRD 98, 102005
(2018)).  Where ``d`` is dominated by the accelerometer's integrated error ``H`` falls to
0 and nothing is removed, so the correction only ever acts where the data show readout
noise.  A force on the mass (a glitch, the excitation) moves both sensors and is not in
``d``.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from tmopt.mismatch.noise_model import band_edges

__all__ = ["readout_noise", "MIN_SEGMENT"]

#: Segments shorter than this [samples] get no estimate (too few bins for a spectrum).
MIN_SEGMENT = 64
#: The plateau is the level of ``d``'s periodogram above ``fs / PLATEAU_FROM``.
PLATEAU_FROM = 8.0


def readout_noise(x: np.ndarray, kin_residual: np.ndarray, segments, fs: float) -> np.ndarray:
    """Estimated readout noise ``n_r`` (4, N) of the positions ``x`` (4, N).

    ``kin_residual`` (4, rows): the exact ZOH kinematic residual, one row per sample
    ``n = a + 1 .. b - 2`` of each gap-free segment ``(a, b)`` in ``segments`` (the rows
    of :func:`tmopt.mismatch.fit.kinematic_target`).  Segments shorter than
    :data:`MIN_SEGMENT` are left at 0."""
    out = np.zeros_like(x, dtype=float)
    at = 0
    for a, b in segments:
        m = b - a
        rows = kin_residual[:, at : at + max(m - 2, 0)]
        at += max(m - 2, 0)
        if m >= MIN_SEGMENT:
            out[:, a:b] = _segment_noise(rows, m, fs)
    return out


def _segment_noise(rows: np.ndarray, m: int, fs: float, min_gain: float = 0.0) -> np.ndarray:
    """One segment: the double integral of its kinematic rows, a straight line taken out,
    Wiener-weighted by its own spectrum (mirror-extended: no jump at the wrap).
    ``min_gain``: bins whose gain is below it are left out (0: none; a probe's knob,
    ``experiments/mismatch_true_position_probe.py``)."""
    d = np.zeros((rows.shape[0], m))
    d[:, 2:] = np.cumsum(np.cumsum(rows, axis=1), axis=1)
    d = signal.detrend(d, axis=1, type="linear")
    xf = np.fft.rfft(np.concatenate([d, d[:, ::-1]], axis=1), axis=1)
    f = np.fft.rfftfreq(2 * m, 1.0 / fs)
    p = np.abs(xf) ** 2
    # band medians: both levels are medians of chi^2_2 bins, so their ratio needs no ln 2
    smooth = np.full_like(p, np.inf)  # the DC bin: the line's, nothing to estimate
    for lo, hi in band_edges(f[1:]):
        smooth[:, 1 + lo : 1 + hi] = np.median(p[:, 1 + lo : 1 + hi], axis=1, keepdims=True)
    plateau = np.median(p[:, f >= fs / PLATEAU_FROM], axis=1, keepdims=True)
    gain = np.clip(plateau / smooth, 0.0, 1.0)
    gain[gain < min_gain] = 0.0
    return np.fft.irfft(gain * xf, n=2 * m, axis=1)[:, :m]
