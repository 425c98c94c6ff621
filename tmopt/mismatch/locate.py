"""Locate a mismatch: where the whitened residual exceeds what the noise model explains.

The residual is first whitened by its noise model (:mod:`tmopt.mismatch.noise_model`), so
"the noise floor" is 1 everywhere and every statistic has a known null distribution:

* **frequency** -- Bartlett periodogram (``segments`` non-overlapping pieces, summed over
  channels): each bin is ``chi^2_{2 S C} / (2 S C)`` under the noise model; bins above the
  Bonferroni threshold are merged into bands ``[lo, hi]`` Hz;
* **time** -- mean square about zero in non-overlapping windows of 1, 10 and 100 s:
  ``chi^2_{C W}/(C W)``; transients (glitches) and drifts light up windows;
* **channels** -- the 2-D direction of the excess in the f_B-free plane compared with each
  axis's direction (equation group), or the axis itself (kinematic group);
* **per-tone transfer** -- residual over motion at each excitation line, the classic
  signature (Congedo et al., PRD 85, 122004 (2012)): flat real = stiffness, ~w^2 = gain,
  ~w^3 in quadrature = delay;
* **coherence** with witness channels (y readouts, forces, attitude) in the flagged bands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal, stats

from tmopt.mismatch.fit import AXES, excitation_tones

__all__ = ["Locations", "frequency_bands", "time_windows", "axis_directions", "locate", "rescaled",
           "tone_transfer", "witness_coherence", "excitation_tones"]  # fmt: skip


@dataclass
class Locations:
    frequency_hz: list[list[float]] = field(default_factory=list)
    time_s: list[list[float]] = field(default_factory=list)
    channels: list[str] = field(default_factory=list)
    min_p: float = 1.0  # smallest Bonferroni-adjusted p of any bin or window

    @property
    def any(self) -> bool:
        return bool(self.frequency_hz or self.time_s)

    def as_dict(self) -> dict:
        return {"frequency_hz": self.frequency_hz, "time_s": self.time_s,
                "channels": self.channels}  # fmt: skip


def _merge(flags: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[list[float]]:
    out: list[list[float]] = []
    for i in np.flatnonzero(flags):
        if out and lo[i] <= out[-1][1] + 1e-12:
            out[-1][1] = float(hi[i])
        else:
            out.append([float(lo[i]), float(hi[i])])
    return out


def frequency_bands(white: np.ndarray, fs: float, alpha: float, segments: int = 4):
    """Bands (list of [lo, hi] Hz) whose whitened power exceeds the noise floor.

    Returns ``(bands, min_p, freqs, level)`` with ``level`` the periodogram normalised to
    the floor (1 under the noise model).
    """
    c, m = white.shape
    seg = m // segments
    if seg < 8:
        return [], 1.0, np.zeros(0), np.zeros(0)
    pieces = white[:, : seg * segments].reshape(c, segments, seg)
    per = np.abs(np.fft.rfft(pieces, axis=2)) ** 2 / seg
    level = per.mean(axis=(0, 1))
    dof = 2 * segments * c
    freqs = np.fft.rfftfreq(seg, 1 / fs)
    keep = slice(1, None)  # the mean is fitted (bias terms): DC carries no test
    p = stats.chi2.sf(level[keep] * dof, dof) * (level.size - 1)
    flags = np.concatenate([[False], p < alpha])
    df = fs / seg
    bands = _merge(flags, np.maximum(freqs - df / 2, 0), freqs + df / 2)
    return bands, float(min(1.0, p.min())), freqs, level


def time_windows(white: np.ndarray, time: np.ndarray, fs: float, alpha: float,
                 scales: tuple[float, ...] = (1.0, 10.0, 100.0)):  # fmt: skip
    """Windows (list of [t0, t1] s) whose whitened mean square exceeds the noise floor."""
    c, m = white.shape
    tests = []
    for w_s in scales:
        w = int(round(w_s * fs))
        if w < 2 or w > m // 4:
            continue
        nwin = m // w
        ms = (white[:, : nwin * w] ** 2).reshape(c, nwin, w).sum(axis=(0, 2))
        p = stats.chi2.sf(ms, c * w)
        starts = time[: nwin * w : w]
        ends = time[w - 1 : nwin * w : w] + 1.0 / fs  # a window may span a gap
        tests.append((p, starts, ends))
    total = sum(t[0].size for t in tests)
    if not total:
        return [], 1.0
    flagged, min_p = [], 1.0  # per scale, finest first
    for p, t0, t1 in tests:
        padj = np.minimum(p * total, 1.0)
        min_p = min(min_p, float(padj.min()))
        flagged.append(_merge(padj < alpha, t0, t1))
    # a coarse window that holds a finer flagged window is reported by the finer one
    kept: list[list[float]] = []
    for k, wins in enumerate(flagged):
        finer = [w for f in flagged[:k] for w in f]
        kept += [w for w in wins if not any(w[0] <= f[0] and f[1] <= w[1] for f in finer)]
    kept.sort()
    merged: list[list[float]] = []
    for a, b in kept:
        if merged and a <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    return merged, min_p


def axis_directions(basis: np.ndarray, chol: np.ndarray) -> np.ndarray:
    """Unit directions (2, 4) of a single-axis disturbance in the spatially whitened plane."""
    d = np.linalg.solve(chol, basis.T)
    return d / np.linalg.norm(d, axis=0)


def excess_axes(white: np.ndarray, dirs: np.ndarray, fs: float, bands: list[list[float]],
                cos_min: float = 0.98) -> list[str]:  # fmt: skip
    """Axes whose direction matches the principal direction of the excess power (white
    noise model: ``white`` is spatially whitened and ``dirs`` are in that plane)."""
    m = white.shape[1]
    x = np.fft.rfft(white, axis=1)
    f = np.fft.rfftfreq(m, 1 / fs)
    mask = _band_mask(f, bands)
    xs = x[:, mask]
    mom = np.real(xs @ xs.conj().T) / m - np.eye(white.shape[0]) * mask.sum() / f.size
    return _principal_axes(mom, dirs, cos_min)


def _band_mask(f: np.ndarray, bands: list[list[float]]) -> np.ndarray:
    mask = np.zeros(f.size, bool)
    for lo, hi in bands:
        mask |= (f >= lo) & (f <= hi)
    if not mask.any():
        mask[:] = True
    return mask


def _principal_axes(mom: np.ndarray, dirs: np.ndarray, cos_min: float) -> list[str]:
    w, v = np.linalg.eigh(mom)
    if w[-1] <= 0:
        return []
    d = dirs / np.linalg.norm(dirs, axis=0)
    cos = np.abs(v[:, -1] @ d)
    return [AXES[a] for a in np.argsort(-cos) if cos[a] >= cos_min]


def excess_axes_physical(residual: np.ndarray, noise, fs: float, bands: list[list[float]],
                         dirs: np.ndarray, window: tuple[float, float] | None = None,
                         time: np.ndarray | None = None,
                         cos_min: float = 0.98) -> list[str]:  # fmt: skip
    """Axes whose direction in the physical f_B-free plane (``dirs`` (2, 4), the rows of
    the null basis) matches the principal direction of the excess cross-spectral power
    ``sum (X X^H - S(f))`` over the flagged bands (or, for a time window, of the excess
    second moment of the whitened-then-unwhitened... simply the residual in the window
    minus the noise model's covariance).  Works for any coloured noise model."""
    if window is not None and time is not None:
        sel = (time >= window[0]) & (time < window[1])
        r = residual[:, sel]
        if r.shape[1] < 2:
            return []
        mom = (r @ r.T) / r.shape[1] - noise.cov
        return _principal_axes(mom, dirs, cos_min)
    mom = np.zeros((residual.shape[0], residual.shape[0]))
    for a, b in noise.layout.bounds:
        m = b - a
        if m < 16:
            continue
        from tmopt.mismatch.noise_model import taper

        win = taper(m, noise.taper_fraction)
        norm = math.sqrt(float(np.mean(win**2)) * m)
        xf = np.fft.rfft(residual[:, a:b] * win, axis=1) / norm
        f = np.fft.rfftfreq(m, 1 / fs)
        mask = _band_mask(f, bands)
        s = noise.matrix(f[mask])
        xs = xf[:, mask]
        mom += np.real(xs @ xs.conj().T) - np.real(s.sum(axis=0))
    return _principal_axes(mom, dirs, cos_min)


def segment_bands(white: np.ndarray, fs: float, alpha: float, layout=None):
    """:func:`frequency_bands` of each gap-free segment separately (Bonferroni over
    segments), merged: a segment's whitened series is white on its own frequency grid,
    but the concatenation of segments of different lengths is not at frequencies below
    the shorter ones' resolution.  Returns (bands, min_p)."""
    bounds = [(0, white.shape[1])] if layout is None else list(layout.bounds)
    bounds = [(a, b) for a, b in bounds if b - a >= 32]
    if not bounds:
        return [], 1.0
    out, min_p = [], 1.0
    for a, b in bounds:
        bands, p, *_ = frequency_bands(white[:, a:b], fs, alpha / len(bounds))
        out += bands
        min_p = min(min_p, p * len(bounds))
    out.sort()
    merged: list[list[float]] = []
    for lo, hi in out:
        if merged and lo <= merged[-1][1] + 1e-12:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return merged, float(min(1.0, min_p))


def rescaled(white: np.ndarray, interior: np.ndarray | None = None) -> np.ndarray:
    """Each whitened channel divided by its robust standard deviation (MAD over the
    ``interior`` samples, away from tapered segment ends): the tests then do not depend
    on the noise model's overall level, only on its shape, and a transient or a line
    hardly moves the scale."""
    out = np.array(white, dtype=float)
    for i, row in enumerate(out):
        nz = row[interior] if interior is not None else row
        nz = nz[nz != 0]
        if nz.size > 16:
            s = 1.4826 * float(np.median(np.abs(nz - np.median(nz))))
            if s > 0:
                out[i] = row / s
    return out


def locate(
    white: np.ndarray,
    time: np.ndarray,
    fs: float,
    alpha: float,
    dirs: np.ndarray | None = None,
    names: tuple[str, ...] | None = None,
    residual: np.ndarray | None = None,
    noise=None,
    interior: np.ndarray | None = None,
    layout=None,
    local: tuple[np.ndarray, np.ndarray] | None = None,
) -> Locations:
    """Frequency bands, time windows and channels of the excess in one residual group.

    ``alpha`` is shared between the frequency and time tests (Bonferroni over both).
    Channels: with ``residual`` and ``noise`` (equation group), from the direction of the
    excess in the physical f_B-free plane (``dirs`` = the null basis's rows, (2, 4)); with
    ``dirs`` alone, in the spatially whitened plane (white noise); with ``names``
    (kinematic group, one channel per axis) from the channels that carry the excess.
    ``local``: (whitened series, mask) of uniform variance along the record
    (:meth:`~tmopt.mismatch.noise_model.NoiseModel.whiten_local`) for the time test, when
    ``white``'s variance follows a taper (Hann: blind near every segment end).
    """
    white = rescaled(white, interior)
    timed = white if local is None else rescaled(local[0], local[1])
    bands, pf = segment_bands(white, fs, alpha / 2, layout)
    wins, pt = time_windows(timed, time, fs, alpha / 2)
    loc = Locations(bands, wins, [], min(1.0, 2 * min(pf, pt)))
    if not loc.any:
        return loc
    if residual is not None and noise is not None and dirs is not None:
        chans = excess_axes_physical(residual, noise, fs, bands, dirs) if bands else []
        for w in wins:
            chans += [a for a in excess_axes_physical(residual, noise, fs, [], dirs, tuple(w),
                                                      time) if a not in chans]  # fmt: skip
        loc.channels = chans
    elif dirs is not None:
        loc.channels = excess_axes(white, dirs, fs, bands)
    elif names is not None:
        for i, nm in enumerate(names):
            b, p1 = segment_bands(white[i : i + 1], fs, alpha / 2, layout)
            w, p2 = time_windows(timed[i : i + 1], time, fs, alpha / 2)
            if b or w:
                loc.channels.append(nm)
    return loc


def tone_transfer(residual_axis: np.ndarray, x_axis: np.ndarray, fs: float,
                  tones: list[float]) -> list[dict]:  # fmt: skip
    """Residual / displacement at each tone (complex): |T| [s^-2] and phase [deg].

    Flat real T = a stiffness error; real T ~ w^2 = a gain error; imaginary T ~ w^3 = a
    delay (Congedo et al. 2012; Grynagier, Ziegler, Fichter, IEEE TAES 49, 2013).
    """
    m = x_axis.size
    t = np.arange(m) / fs
    out = []
    for f0 in tones:
        e = np.exp(-2j * math.pi * f0 * t) * np.hanning(m)
        xr, rr = np.sum(x_axis * e), np.sum(residual_axis * e)
        tr = rr / xr if abs(xr) > 0 else 0j
        out.append({"frequency_hz": f0, "magnitude": float(abs(tr)),
                    "phase_deg": float(np.degrees(np.angle(tr)))})  # fmt: skip
    return out


def witness_coherence(series: np.ndarray, witnesses: dict[str, np.ndarray], fs: float,
                      bands: list[list[float]], alpha: float) -> dict[str, float]:  # fmt: skip
    """Largest magnitude-squared coherence of ``series`` with each witness in ``bands``,
    kept when above the null threshold ``1 - alpha^(1/(K-1))`` (K Welch segments)."""
    if not bands:
        return {}
    nper = max(16, series.size // 8)
    k = 2 * series.size // nper - 1  # 50 % overlap
    thr = 1 - alpha ** (1 / max(k - 1, 1))
    out = {}
    for name, w in witnesses.items():
        if np.ptp(w) == 0:
            continue
        f, coh = signal.coherence(series, w, fs=fs, nperseg=nper)
        sel = np.zeros(f.size, bool)
        for lo, hi in bands:
            sel |= (f >= lo) & (f <= hi)
        if sel.any() and coh[sel].max() > thr:
            out[name] = float(coh[sel].max())
    return out
