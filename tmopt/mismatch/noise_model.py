"""Noise models of the residual groups: what "consistent with noise" means.

Two groups of residuals are fitted (see :mod:`tmopt.mismatch.fit`): the **equation** group
(two f_B-free combinations of the per-axis equation errors of Eqs. 9-10) and the
**kinematic** group (four readout-vs-accelerometer consistency residuals).  Real
instruments make both coloured: LISA Pathfinder's acceleration noise rises as 1/f below
~1 mHz, its readout noise has a 1/f corner (Armano et al., PRL 116, 231101 (2016); PRL
120, 061101 (2018)), and a second difference of white readout noise is blue.  So every
group is modelled as stationary Gaussian noise with a smooth **cross-spectral matrix**
``S(f)`` (C x C per frequency), estimated from the data, never taken from Table 1:

* estimate (:meth:`NoiseModel.estimate`): the residual is cut into its gap-free segments
  (the ``layout``); each segment tapered (Tukey 10 %: a red or blue series' boundary
  terms would leak into every bin of a rectangular window) and transformed; the
  periodograms are pooled over segments.  Each channel's PSD is a cubic spline in
  ``log f`` for ``log S`` (4 knots per decade, at least 8 bins between knots, so the
  lowest decade -- a handful of bins -- gets one or two degrees of freedom) fitted by
  maximising the Whittle likelihood ``-sum(log S + I/S)`` (Whittle 1953; concave in the
  coefficients, Newton); bins more than 20x above the fit (lines, p = e^-20) are dropped
  and the fit repeated, so a line is not absorbed.  Transients: a glitch of
  matched-filter SNR rho spreads rho^2 over N/2 bins (+4 % for rho = 20, N = 20000) and
  is removed from the residual once the glitch effect is selected.  Channel coupling:
  by default the coherence of the standardised channels (Gnanadesikan-Kettenring
  identity on the periodograms of ``X_i +- X_j`` and ``X_i +- i X_j``, medians over
  quarter-decade bands / ln 2), interpolated linearly in log f; or (``cross=
  "regression"``, an option) sequential regression (the modified Cholesky form ``S = L D
  L^H``, Rosen & Stoffer, Biometrika 94, 335 (2007)): channel j's transform regressed on
  channels < j's per quarter-decade band (weighted least squares, line bins left out),
  the transfer interpolated linearly in log f, each innovation with its own log-PSD
  spline (:func:`_regression_spectrum`);
* whiten (:meth:`NoiseModel.whiten`): per segment, taper, transform, multiply by the
  inverse Cholesky factor of ``S(f)`` at each bin (Whittle's circulant approximation),
  transform back: unit-variance white noise when the model holds;
* ``white`` kind: ``S(f)`` = the robust spatial covariance (first differences, MAD)
  at every frequency -- round one's equation-group model, kept for instruments known to
  be white (``Settings(noise="white")``); with a fitted power law per channel
  (``with_red``) it is round one's ``colored_noise`` alternative.

Levels are always estimated from the data: a recording from another simulator or the real
instrument may have other noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tmopt.mismatch.expected_periodogram import SegmentKernel, autocovariance

__all__ = ["robust_cov", "NoiseModel", "Layout", "fit_red", "red_shape", "RED_EXPONENTS",
           "band_edges"]  # fmt: skip

_MAD = 1.4826  # MAD -> standard deviation for Gaussian data
_LN2 = math.log(2.0)
TAPER = 0.1  # Tukey fraction of every segment
#: Block length [samples] of :meth:`NoiseModel.whiten_local` (overlap-added Hann blocks).
LOCAL_BLOCK = 256


def _robust_var(v: np.ndarray) -> float:
    med = np.median(v)
    return float((_MAD * np.median(np.abs(v - med))) ** 2)


def robust_cov(residual: np.ndarray, layout: Layout | None = None) -> np.ndarray:
    """Robust covariance of white noise from first differences (C, M) -> (C, C).

    ``diff(r)/sqrt(2)`` has the covariance of white ``r`` but ignores slow structure
    (drifts, low-frequency lines); MAD scales ignore transients (glitches).  Off-diagonal
    terms by the Gnanadesikan-Kettenring identity ``cov(a,b) = (var(a+b) - var(a-b))/4``.
    Differences are taken within segments (never across a gap).
    """
    layout = Layout.whole(residual.shape[1]) if layout is None else layout
    d = np.concatenate([np.diff(residual[:, a:b], axis=1) for a, b in layout.bounds],
                       axis=1) / math.sqrt(2.0)  # fmt: skip
    c = d.shape[0]
    cov = np.empty((c, c))
    for i in range(c):
        cov[i, i] = _robust_var(d[i])
        for j in range(i):
            cov[i, j] = cov[j, i] = 0.25 * (_robust_var(d[i] + d[j]) - _robust_var(d[i] - d[j]))
    return _floor_psd(cov)


def _floor_psd(m: np.ndarray, rel: float = 1e-12) -> np.ndarray:
    """Nearest Hermitian positive-definite matrix (eigenvalues floored at rel x trace)."""
    m = 0.5 * (m + np.conj(np.swapaxes(m, -1, -2)))
    w, v = np.linalg.eigh(m)
    tr = np.maximum(np.sum(np.abs(w), axis=-1, keepdims=True), 1e-300)
    w = np.maximum(w, rel * tr)
    return (v * w[..., None, :]) @ np.conj(np.swapaxes(v, -1, -2))


@dataclass(frozen=True)
class Layout:
    """Gap-free segments ``[(start, stop), ...]`` of a group's sample axis (length n)."""

    bounds: tuple[tuple[int, int], ...]
    n: int

    @classmethod
    def whole(cls, n: int) -> Layout:
        return cls(((0, n),), n)

    @property
    def longest(self) -> tuple[int, int]:
        return max(self.bounds, key=lambda s: s[1] - s[0])


#: Fewest samples a taper spans at each end of a segment (short segments get a larger
#: Tukey fraction, up to Hann): a 64-sample segment with a 10 % taper is nearly
#: rectangular, and steep spectra leak through it.
TAPER_SAMPLES = 64


def taper(m: int, fraction: float = TAPER) -> np.ndarray:
    """Tukey window of an m-sample segment: ``fraction`` of it tapered, but at least
    :data:`TAPER_SAMPLES` at each end (Hann at most).  The boundary terms of a red or blue
    series would otherwise leak into every low-frequency bin (a rectangular window raised
    the floor 30x in round one)."""
    from scipy.signal.windows import tukey

    if m <= 2:
        return np.ones(m)
    return tukey(m, min(1.0, max(fraction, 2.0 * TAPER_SAMPLES / m)))


def band_edges(f: np.ndarray, min_bins: int = 8, per_decade: int = 10) -> list[tuple[int, int]]:
    """Index ranges of log-spaced bands over sorted frequencies ``f`` (>= ``min_bins`` each)."""
    edges = [0]
    while edges[-1] < f.size:
        lo = f[edges[-1]]
        hi = lo * 10 ** (1 / per_decade)
        nxt = max(edges[-1] + min_bins, int(np.searchsorted(f, hi)))
        edges.append(min(nxt, f.size))
    if len(edges) > 2 and edges[-1] - edges[-2] < min_bins:
        edges.pop(-2)
    return list(zip(edges[:-1], edges[1:]))


def _periodograms(x: np.ndarray, fs: float, window: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tapered transforms of a (C, M) piece: frequencies (F,) and X (C, F) normalised so
    that ``E|X|^2`` is the two-sided PSD times fs (= variance per bin for white noise)."""
    m = x.shape[1]
    norm = math.sqrt(float(np.mean(window**2)) * m)
    return np.fft.rfftfreq(m, 1 / fs), np.fft.rfft(x * window, axis=1) / norm


def _cross_stats(xf: np.ndarray) -> np.ndarray:
    """Periodogram combinations (P, F) whose medians give every entry of S: ``|X_i|^2``,
    then per pair ``|X_i + X_j|^2, |X_i - X_j|^2, |X_i + i X_j|^2, |X_i - i X_j|^2``."""
    c = xf.shape[0]
    rows = [np.abs(xf[i]) ** 2 for i in range(c)]
    for i in range(c):
        for j in range(i):
            for z in (1, -1, 1j, -1j):
                rows.append(np.abs(xf[i] + z * xf[j]) ** 2)
    return np.array(rows)


def _assemble(stats: np.ndarray, c: int) -> np.ndarray:
    """(P, B) robust levels -> (B, C, C) Hermitian matrices (GK identity)."""
    b = stats.shape[1]
    out = np.zeros((b, c, c), complex)
    for i in range(c):
        out[:, i, i] = stats[i]
    k = c
    for i in range(c):
        for j in range(i):
            pp, pm, pi_, mi = stats[k], stats[k + 1], stats[k + 2], stats[k + 3]
            k += 4
            # |Xi + z Xj|^2 = Sii + Sjj + 2 Re(conj(z) Sij) with Sij = E[Xi conj(Xj)]
            re = 0.25 * (pp - pm)
            im = 0.25 * (pi_ - mi)
            out[:, i, j] = re + 1j * im
            out[:, j, i] = re - 1j * im
    return out


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
class NoiseModel:
    """Stationary Gaussian noise of C channels with cross-spectral matrix ``S(f)``.

    ``kind``: ``smoothed`` (robust Whittle estimate: log-PSD splines ``knots``, ``coefs``
    (C, K) and coherence bands ``coh_f`` (B,) [Hz], ``coh`` (B, C, C)), ``white``
    (``cov`` at every frequency), or ``white`` with
    ``red`` = [(knee [cycles/sample], gamma, level)] per spatially whitened channel (round
    one's power-law model).  ``S`` is in units of the per-sample variance (two-sided PSD
    times fs).  ``cov``: the white-level spatial covariance (first differences), also used
    to read directions.  ``layout``: the segments that :meth:`whiten` treats separately.
    """

    kind: str
    cov: np.ndarray
    layout: Layout
    fs: float
    knots: np.ndarray | None = None
    coefs: np.ndarray | None = None  # (C, K): log PSD spline per channel
    coh_f: np.ndarray | None = None
    coh: np.ndarray | None = None  # (B, C, C)
    red: list[tuple[float, float, float]] = field(default_factory=list)
    taper_fraction: float = TAPER
    #: (B, C, C) strictly lower: channel j's regression on channels < j per band at
    #: ``coh_f`` (the ``regression`` cross-spectrum); ``coefs`` are then the innovations'
    #: log-PSD splines and ``coh`` is None.
    transfer: np.ndarray | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------------ estimation

    @classmethod
    def estimate(cls, residual: np.ndarray, layout: Layout, fs: float,
                 kind: str = "smoothed", taper_fraction: float = TAPER,
                 coupled: bool = True, cross: str | None = None,
                 debias: str | None = None) -> NoiseModel:  # fmt: skip
        """Estimate from a residual (C, M) laid out in ``layout``; ``taper_fraction`` of
        each segment is tapered (Tukey; 1 = Hann).  ``coupled=False``: independent
        channels (a diagonal model; no coherence to estimate where none is physical).
        ``cross``: how coupled channels' cross-spectrum is estimated, ``regression`` or
        ``coherence`` (default :data:`CROSS_SPECTRUM`; see :func:`_regression_spectrum`).
        ``debias``: how the spline meets the pooled periodogram (default :data:`DEBIAS`).
        Transients are gated out of the estimate (:func:`_transient_gate`), the gate
        found again with the gated model, up to GATE_ROUNDS times: a loud glitch inflates
        the first estimate's low frequencies, its whitened tail is then high-passed away and
        only the onset is gated (a 4 s glitch at SNR ~100 left 3x excess below 0.03 Hz)."""
        cov = robust_cov(residual, layout)
        if kind == "white":
            return cls("white", cov, layout, fs)
        if kind != "smoothed":
            raise ValueError(f"noise kind must be 'smoothed' or 'white'; got {kind!r}")
        cross = CROSS_SPECTRUM if cross is None else cross
        if cross not in CROSS_KINDS:
            raise ValueError(f"cross must be one of {CROSS_KINDS}; got {cross!r}")
        debias = DEBIAS if debias is None else debias
        if debias not in DEBIAS_KINDS:
            raise ValueError(f"debias must be one of {DEBIAS_KINDS}; got {debias!r}")
        parts = _smoothed_spectrum(residual, layout, fs, taper_fraction, coupled, cross=cross,
                                   debias=debias)  # fmt: skip
        model = cls._smoothed(cov, layout, fs, parts, taper_fraction)
        gate = None
        for _ in range(GATE_ROUNDS):
            new = _transient_gate(model.whiten(residual), layout, fs, model.whitened_variance())
            if new is None:
                return model
            if gate is not None:
                new = np.minimum(new, gate)  # a gate only grows: the rounds converge
                if np.array_equal(new, gate):
                    return model
            gate = new
            parts = _smoothed_spectrum(residual, layout, fs, taper_fraction, coupled, gate,
                                       cross, debias)  # fmt: skip
            model = cls._smoothed(cov, layout, fs, parts, taper_fraction)
        return model

    @classmethod
    def _smoothed(cls, cov, layout: Layout, fs: float, parts: tuple,
                  taper_fraction: float) -> NoiseModel:  # fmt: skip
        knots, coefs, coh_f, coh, transfer = parts
        return cls("smoothed", cov, layout, fs, knots, coefs, coh_f, coh,
                   taper_fraction=taper_fraction, transfer=transfer)  # fmt: skip

    def with_red(self, residual: np.ndarray) -> NoiseModel:
        """The white spatial part with a power-law red spectrum fitted per channel."""
        w = self.spatial(residual)
        return NoiseModel("white", self.cov, self.layout, self.fs,
                          red=[fit_red(c)[:3] for c in w])  # fmt: skip

    def relayout(self, layout: Layout) -> NoiseModel:
        """The same spectrum for another sample layout (e.g. after alignment, or a planned
        run's)."""
        return NoiseModel(self.kind, self.cov, layout, self.fs, self.knots, self.coefs,
                          self.coh_f, self.coh, list(self.red), self.taper_fraction,
                          transfer=self.transfer)  # fmt: skip

    # ------------------------------------------------------------------ spectrum

    @property
    def channels(self) -> int:
        return self.cov.shape[0]

    def matrix(self, f_hz: np.ndarray) -> np.ndarray:
        """``S(f)`` (F, C, C) at frequencies [Hz] (per-sample variance units)."""
        c = self.channels
        if self.kind == "smoothed":
            f_hz = np.asarray(f_hz, float)
            sd = np.exp(0.5 * (_design(np.log(np.maximum(f_hz, 1e-300)), self.knots)
                               @ self.coefs.T))  # (F, C)
            if self.transfer is not None:  # S = L D L^H, L = (I - B)^-1
                lmat = np.linalg.inv(np.eye(c) - _interp_bands(f_hz, self.coh_f, self.transfer))
                return (lmat * (sd**2)[:, None, :]) @ np.conj(np.swapaxes(lmat, 1, 2))
            coh = _interp_bands(f_hz, self.coh_f, self.coh)
            return coh * sd[:, :, None] * sd[:, None, :]
        base = np.broadcast_to(self.cov.astype(complex), (f_hz.size, c, c)).copy()
        if not self.red:
            return base
        chol = np.linalg.cholesky(self.cov)
        fc = np.maximum(f_hz / self.fs, 1e-12)
        diag = np.array([lv * red_shape(fc, k, g) for k, g, lv in self.red]).T  # (F, C)
        return np.einsum("ij,fj,kj->fik", chol, diag, chol).astype(complex)

    def _whitener(self, m: int, segment: bool = True) -> np.ndarray:
        """Inverse Cholesky factors (F, C, C) on the rfft grid of an m-sample segment.

        For a segment (``segment``) the DC bin is set to zero: the spectrum there is not
        estimated (no periodogram bin), and a tapered segment's weighted mean, divided by
        the lowest estimated level, put a different offset on every segment's whitened
        series -- low-frequency "excess" across gaps.  Every group fits an offset per
        segment, so the mean carries no test."""
        key = ("w", m, segment)
        if key not in self._cache:
            f = np.fft.rfftfreq(m, 1 / self.fs)
            s = _floor_psd(self.matrix(f))
            w = np.linalg.inv(np.linalg.cholesky(s))
            if segment and self.tapered:
                w[0] = 0.0
            self._cache[key] = w
        return self._cache[key]

    def spatial(self, arr: np.ndarray) -> np.ndarray:
        """Spatial whitening by the white-level covariance (directions, red fits)."""
        return np.linalg.solve(np.linalg.cholesky(self.cov), arr)

    @property
    def tapered(self) -> bool:
        return self.kind == "smoothed"

    def whiten(self, arr: np.ndarray) -> np.ndarray:
        """(C, M) -> (C, M): unit-variance white noise when the model holds.

        Per segment of the layout: taper (smoothed kind), transform, ``L(f)^-1 X(f)``,
        transform back.  Rows that are zero throughout are left zero (regressors on one
        axis of a group cost nothing).
        """
        if self.kind == "white" and not self.red:
            return self.spatial(arr)
        out = np.zeros(arr.shape)
        for a, b in self.layout.bounds:
            m = b - a
            win = taper(m, self.taper_fraction) if self.tapered else np.ones(m)
            out[:, a:b] = self._whitened(arr[:, a:b], win)
        return out

    def _whitened(self, piece: np.ndarray, win: np.ndarray) -> np.ndarray:
        """One stretch (C, m) times the window ``win`` (m,): ``L(f)^-1 X(f)`` back in time."""
        m = piece.shape[1]
        wf = np.einsum("fij,jf->if", self._whitener(m), np.fft.rfft(piece * win, axis=1))
        return np.fft.irfft(wf, n=m, axis=1)

    def whiten_local(self, arr: np.ndarray, block: int = LOCAL_BLOCK) -> tuple[np.ndarray,
                                                                           np.ndarray]:
        """(C, M) -> ((C, M), (M,) bool): a whitened series of uniform variance along
        each segment, for tests in time, and where it holds.

        :meth:`whiten` tapers a whole segment; under a Hann taper (the kinematic group,
        whose blue noise leaks through anything flatter) its output's variance follows
        the taper, ~0 over the first and last 10-20 % of every segment, and a transient
        there -- a readout burst next to a gap -- is whitened away.  Here each segment is
        cut into ``block``-sample periodic-Hann blocks at 50 % overlap, each block
        whitened with the same spectrum and the blocks added: periodic Hann windows at
        half-block hops sum to one (constant overlap-add; Allen & Rabiner, Proc. IEEE 65,
        1558 (1977)), so the output has unit variance except in the half block at each
        segment end (False in the mask, set to zero).  Segments shorter than two blocks
        use :meth:`whiten` (their interior, :meth:`interior`, as the mask)."""
        from scipy.signal.windows import hann

        if not self.tapered:
            return self.whiten(arr), np.ones(arr.shape[1], bool)
        out = np.zeros(arr.shape)
        mask = self.interior()  # short segments keep whiten's tapered interior
        win = hann(block, sym=False)
        hop = block // 2
        for a, b in self.layout.bounds:
            m = b - a
            if m < 2 * block:
                out[:, a:b] = self._whitened(arr[:, a:b], taper(m, self.taper_fraction))
                continue
            for s0 in range(a, b - block + 1, hop):
                out[:, s0:s0 + block] += self._whitened(arr[:, s0:s0 + block], win)
            last = a + ((m - block) // hop) * hop + block  # end of the last whole block
            mask[a:b] = False
            mask[a + hop:last - hop] = True
            out[:, a:a + hop] = 0.0
            out[:, last - hop:b] = 0.0
        return out, mask

    def interior(self) -> np.ndarray:
        """(M,) True where every segment's taper is >= 0.9 (there :meth:`whiten` gives
        about unit variance; the tapered ends have less)."""
        mask = np.ones(self.layout.n, bool)
        if self.tapered:
            for a, b in self.layout.bounds:
                mask[a:b] = taper(b - a, self.taper_fraction) >= 0.9
        return mask

    def whitened_variance(self) -> np.ndarray:
        """(M,) expected variance of :meth:`whiten`'s output per sample when the model
        holds: the square of each segment's taper (whitening a tapered segment gives
        tapered white noise; 1 where nothing is tapered).  What a covariance predicted
        for this layout puts in place of the squared whitened residual."""
        out = np.ones(self.layout.n)
        if self.tapered:
            for a, b in self.layout.bounds:
                out[a:b] = taper(b - a, self.taper_fraction) ** 2
        return out

    def whittle_loglik(self, residual: np.ndarray) -> float:
        """The objective the spline fit maximises (:func:`_whittle_spline`) for a residual
        (C, M) under this smoothed model: Whittle's log-likelihood on the pooled tapered
        periodogram the model is fitted to (:func:`_pooled_periodograms`, no gate),
        ``-sum_k (log S(f_k) + I_k / S(f_k))`` (Whittle, J. R. Stat. Soc. B 19, 38 (1957)),
        less the roughness penalty ``ROUGHNESS |D2 beta|^2``, channel by channel.  The
        penalty charges a spectrum for bending into a few emptied bins (clean foreign
        37117's profile ratio: 15.2 without it, 11.7 with; docs/mismatch.md 9.29).  Only
        the diagonal of a coupled model is read.  Adjacent bins of a tapered piece are
        correlated, so a difference of two of these over-counts by
        :meth:`taper_inflation`."""
        if self.kind != "smoothed":
            raise ValueError(f"whittle_loglik needs a smoothed model; this one is {self.kind!r}")
        f, xf, _ = _pooled_periodograms(residual, self.layout, self.fs, self.taper_fraction)
        log_s = (_design(np.log(f), self.knots) @ self.coefs.T).T  # (C, F)
        penalty = ROUGHNESS * float(np.sum(np.diff(self.coefs, 2, axis=1) ** 2))
        return float(-np.sum(log_s + np.abs(xf) ** 2 / np.exp(log_s))) - penalty

    def taper_inflation(self) -> float:
        """``mean(w^4) / mean(w^2)^2`` over the layout's tapered pieces (Hann: 35/18 =
        1.944; untapered: 1): by this factor a sum over the pooled periodogram's bins
        counts a quadratic form of the tapered series as more independent terms than it
        holds (the Satterthwaite factor of a weighted sum of squares)."""
        w = [taper(b - a, self.taper_fraction) for a, b in self.layout.bounds if b - a >= 16]
        if not w:
            return 1.0
        w = np.concatenate(w)
        return float(np.mean(w**4) / np.mean(w**2) ** 2)

    def whiten_template(self, arr: np.ndarray, nfft: int) -> np.ndarray:
        """Stationary whitening of a short template (C, M) without taper, on a zero-padded
        grid of ``nfft`` points: the whitening filter applied to a signal away from the
        segment ends (used to scan a template across the record)."""
        xf = np.fft.rfft(arr, nfft, axis=1)
        wf = np.einsum("fij,jf->if", self._whitener(nfft, segment=False), xf)
        return np.fft.irfft(wf, nfft, axis=1)

    def loglik(self, residual: np.ndarray) -> float:
        """Gaussian (Whittle) log-likelihood with the overall scale profiled."""
        e = self.whiten(residual)
        n = e.size
        ll = -0.5 * n * (math.log(max(float(np.sum(e**2)), 1e-300) / n) + 1 + math.log(2 * math.pi))
        for a, b in self.layout.bounds:
            w = self._whitener(b - a)[1:]  # the DC bin carries no test (zeroed)
            # log det S per bin = -2 log|det L^-1|; both halves of the spectrum
            logdet = -2 * np.sum(np.log(np.maximum(np.abs(np.linalg.det(w)), 1e-300)))
            ll -= 0.5 * 2 * float(logdet) * (b - a) / max(2 * (w.shape[0] - 1), 1)
        return ll

    def asd(self, f_hz: np.ndarray) -> np.ndarray:
        """One-sided ASD of each channel (C, F) [unit / sqrt(Hz)]."""
        s = self.matrix(np.asarray(f_hz, float))
        return np.sqrt(np.maximum(np.real(np.einsum("fii->if", s)), 0.0) * 2 / self.fs)

    def describe(self) -> dict:
        out = {
            "kind": self.kind if not self.red else "white + power-law red",
            "std": np.sqrt(np.diag(self.cov)).tolist(),
            "correlation": float(self.cov[0, 1] / math.sqrt(self.cov[0, 0] * self.cov[1, 1]))
            if self.channels > 1 else 0.0,
            "red": [{"knee_cycles_per_sample": k, "exponent": g, "level": lv}
                    for k, g, lv in self.red],
        }  # fmt: skip
        if self.kind == "smoothed":
            f = np.exp(np.unique(self.knots))
            asd = self.asd(f)
            out["asd_hz"] = f.tolist()
            out["asd"] = asd.tolist()
            # low-frequency log-log slope of the PSD (first decade of bands), for words
            lo = f <= f[0] * 10
            if lo.sum() >= 2:
                out["low_f_psd_slope"] = [float(np.polyfit(np.log(f[lo]), 2 * np.log(row[lo]),
                                                           1)[0]) for row in asd]  # fmt: skip
        return out


#: A periodogram bin this many times above the model is a line or a transient (p = e^-20
#: for an exponential variable) and is left out of the fit.
OUTLIER = 20.0
#: Spline knots per decade, and the fewest periodogram bins between two knots.
KNOTS_PER_DECADE = 4
MIN_BINS_PER_KNOT = 8


def _pooled_periodograms(residual: np.ndarray, layout: Layout, fs: float, fraction: float,
                         gate: np.ndarray | None = None):
    """Frequencies (F,) and transforms (C, F) of every segment (tapered as
    :meth:`NoiseModel.whiten` tapers, so estimate and whitening share their leakage; times
    ``gate`` where transients are gated out), pooled and sorted by frequency, DC bins left
    out; and the pooling ``(kernels, order)``: each used segment's
    :class:`~tmopt.mismatch.expected_periodogram.SegmentKernel` (its window, and its
    taper, under which the fit's offset was fitted), and the permutation that sorted the
    concatenated bins (what :func:`_debias_factors` needs to put each bin's expectation
    in its place)."""
    f_all, x_all, kernels = [], [], []
    for a, b in layout.bounds:
        m = b - a
        if m < 16:
            continue
        fit_win = taper(m, fraction)
        win = fit_win if gate is None else fit_win * gate[a:b]
        if not np.any(win):
            continue
        f, xf = _periodograms(residual[:, a:b], fs, win)
        f_all.append(f[1:])
        x_all.append(xf[:, 1:])
        kernels.append(SegmentKernel(win, fit_win))
    f_all = np.concatenate(f_all)
    x_all = np.concatenate(x_all, axis=1)
    order = np.argsort(f_all, kind="stable")
    return f_all[order], x_all[:, order], (kernels, order)


#: How the spline is fitted to the pooled periodogram (docs/mismatch.md 9.23):
#:
#: * ``off`` -- every bin read as the PSD at its frequency (Whittle);
#: * ``offset`` -- every bin against its expectation with the segment's offset fitted
#:   (generalised least squares, as the fit's offset columns are) over its expectation
#:   without: only what the fit takes out is put back, so the estimate keeps the tapered
#:   periodogram's leakage that :meth:`NoiseModel.whiten` shares (a restricted-likelihood
#:   correction; in a piece of ~100 samples the offset takes up to half of the lowest
#:   bin);
#: * ``full`` -- the debiased Whittle likelihood of Sykulski et al. (Biometrika 106, 251
#:   (2019)): every bin against its expectation, leakage included, so the estimate is the
#:   process's PSD -- which the whitening of a tapered segment then does not match (the
#:   kinematic group's blue noise leaks into its lowest bins through the Hann taper).
#:
#: DEBIAS_ROUNDS: fixed-point passes (factors from the last fit, refit on the corrected
#: periodogram).  One pass: a second moved white noise's lowest-bin level by 6 % and
#: cost another 40 % of a nominal fit.
DEBIAS_KINDS = ("off", "offset", "full")
DEBIAS = "offset"
DEBIAS_ROUNDS = 1


def _debias_factors(f: np.ndarray, knots: np.ndarray, coefs: np.ndarray, pooling,
                    fs: float, kind: str) -> np.ndarray:  # fmt: skip
    """(C, F) factor by which each pooled bin's expectation differs from the model's PSD
    at its frequency (:data:`DEBIAS`'s ``kind``), under the log-PSD splines ``coefs``
    (C, K) -- the PSD held at its lowest estimated level below the pooled frequencies, as
    :meth:`NoiseModel.matrix` holds it.  The autocovariance comes from the PSD on a fine
    circle (8x the longest segment), read off the spline by interpolation in log f."""
    kernels, order = pooling
    longest = max(k.m for k in kernels)
    n_grid = 1 << int(math.ceil(math.log2(8 * longest)))  # c(tau) free of wrap-around
    grid = np.log(np.maximum(np.fft.rfftfreq(n_grid, 1 / fs), f[0]))
    nodes = np.linspace(math.log(f[0]), math.log(fs / 2), 2048)
    at_nodes = _design(nodes, knots) @ coefs.T  # (2048, C) log PSD
    grids = {m: np.log(np.maximum(np.fft.rfftfreq(m, 1 / fs), f[0]))
             for m in {k.m for k in kernels}}  # fmt: skip
    out = np.empty((coefs.shape[0], f.size))
    for j in range(coefs.shape[0]):
        acov = autocovariance(np.exp(np.interp(grid, nodes, at_nodes[:, j])))
        parts = []
        for k in kernels:
            psd = np.exp(np.interp(grids[k.m], nodes, at_nodes[:, j]))
            fitted = k.expected(acov, "gls", psd)[1:]
            ref = k.expected(acov, "none")[1:] if kind == "offset" else psd[1:]
            parts.append(np.maximum(fitted, 1e-300) / np.maximum(ref, 1e-300))
        out[j] = np.concatenate(parts)[order]
    return out


def _knots(f: np.ndarray) -> np.ndarray:
    """Cubic B-spline knots in log f: KNOTS_PER_DECADE per decade, at least
    MIN_BINS_PER_KNOT pooled bins apart (so the lowest frequencies, where a decade holds a
    handful of bins, get few degrees of freedom)."""
    u = np.log(f)
    step = math.log(10.0) / KNOTS_PER_DECADE
    inner, last_idx = [], 0
    target = u[0] + step
    while True:
        idx = max(int(np.searchsorted(u, target)), last_idx + MIN_BINS_PER_KNOT)
        if idx >= f.size - MIN_BINS_PER_KNOT:
            break
        inner.append(u[idx])
        last_idx = idx
        target = u[idx] + step
    return np.concatenate([[u[0]] * 4, inner, [u[-1]] * 4])


def _design(u: np.ndarray, knots: np.ndarray) -> np.ndarray:
    from scipy.interpolate import BSpline

    u = np.clip(u, knots[0], knots[-1])
    return BSpline.design_matrix(u, knots, 3).toarray()


#: Roughness penalty on the spline coefficients' second differences (log-PSD units):
#: a P-spline (Eilers & Marx, Stat. Sci. 11, 89 (1996)).  Where a knot interval holds
#: thousands of bins it is negligible; at the lowest decade (a few exponential bins) it
#: keeps one low bin from pulling the fit down by 1000x -- which made the whitening
#: amplify that frequency 30x and buried a glitch (matched-filter statistic 245 -> 4).
ROUGHNESS = 10.0


def _whittle_spline(f: np.ndarray, i: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Coefficients of ``log S(f) = B(log f) beta`` maximising the penalised Whittle
    likelihood ``-sum(log S + I/S) - ROUGHNESS |D2 beta|^2`` (concave; Newton), bins above
    OUTLIER x the fit dropped and the fit repeated."""
    b = _design(np.log(f), knots)
    log_i = np.log(np.maximum(i, 1e-300))
    # in units of the median bin: the B-splines sum to one, so a level is a constant added
    # to every coefficient, and a residual many decades off (a fit of nonsense data whose
    # GLS diverged reached 1e251) neither overflows the ratio nor leaves a singular Hessian
    level = float(np.median(log_i))
    log_i = log_i - level
    keep = np.ones(f.size, bool)
    # start: least squares on log(I) + Euler's gamma (E log of an Exp(1) is -0.5772)
    beta, *_ = np.linalg.lstsq(b, log_i + 0.5772156649, rcond=None)
    k = b.shape[1]
    d2 = np.diff(np.eye(k), 2, axis=0)
    pen = ROUGHNESS * d2.T @ d2 + 1e-8 * np.eye(k)
    for _ in range(2):
        bk, lk = b[keep], log_i[keep]
        for _ in range(30):
            # I/S; far beyond an Exp(1) draw only on a start many decades off
            ratio = np.exp(np.minimum(lk - bk @ beta, RATIO_LOG_MAX))
            grad = bk.T @ (ratio - 1.0) - 2 * pen @ beta
            step = _newton_step(bk, ratio, grad, pen)
            beta = beta + np.clip(step, -5, 5)
            if float(np.max(np.abs(step))) < 1e-6:
                break
        keep = log_i < np.log(OUTLIER) + b @ beta
    return beta + level


def _newton_step(b: np.ndarray, ratio: np.ndarray, grad: np.ndarray,
                 pen: np.ndarray) -> np.ndarray:
    """Newton's step for :func:`_whittle_spline`, or Fisher scoring's (the expected
    Hessian, ``B'B``: each ratio's mean is one) where the observed Hessian is numerically
    singular -- ratios of 1e-12 and 5e21 in one start, a residual 640 e-folds wide."""
    hess = (b * ratio[:, None]).T @ b + 2 * pen
    if np.linalg.cond(hess) < 1e12:
        return np.linalg.solve(hess, grad)
    return np.linalg.solve(b.T @ b + 2 * pen, grad)


#: Largest log of a bin's ratio I/S in the Newton iteration of :func:`_whittle_spline`
#: (e^50: an Exp(1) draw beyond it has probability e^-5e21; only the first steps of a
#: start many decades off reach it, where it bounds the Hessian's entries).
RATIO_LOG_MAX = 50.0


#: Transient gating: windows of this length [s] (at least 8 samples) whose whitened power
#: exceeds the median window by GATE_Z standard errors are left out of the estimate
#: (with one window of margin each side and cosine ramps), unless more than
#: GATE_MAX_FRACTION of the record would go (that is non-stationary noise, not a transient).
GATE_WINDOW_S = 4.0
GATE_Z = 8.0
GATE_MAX_FRACTION = 0.2
GATE_ROUNDS = 3


#: Windows whose expected whitened variance (the taper squared) is below this fraction of
#: unity are neither a reference nor a candidate for the gate: there the taper already
#: takes a transient out of the estimate.
GATE_MIN_VARIANCE = 0.25


def _transient_gate(white: np.ndarray, layout: Layout, fs: float,
                    expected: np.ndarray | None = None) -> np.ndarray | None:  # fmt: skip
    """Weights (M,) in [0, 1] gating out transients (glitches) of a whitened residual, or
    None when there are none.  A glitch of matched-filter SNR rho puts rho^2 into the
    lowest bins it occupies -- the periodogram of a 5 s glitch at SNR 15 was 10x the noise
    below 0.04 Hz -- and the noise model would then hide the very glitch it should reveal
    (LIGO gates loud glitches before estimating its PSD the same way: Usman et al., CQG 33,
    215004 (2016)).

    ``expected`` (M,): the whitened series' variance where the model holds
    (:meth:`NoiseModel.whitened_variance`, the taper squared); each window's power is read
    against it.  Without it, a record cut into ~100-sample Hann-tapered pieces had the
    middles of its pieces (variance ~1) read against a median window of ~0.4, and the gate
    took out 26-31 % of white noise -- and 2-9 % of the samples of a clean flight-like
    record cut into ~100-sample pieces (k38202:32; docs/mismatch.md 9.23)."""
    c, m = white.shape
    w = max(8, int(round(GATE_WINDOW_S * fs)))
    if expected is None:
        expected = np.ones(m)
    power = np.sum(white**2, axis=0)
    flags = np.zeros(m, bool)
    means = []
    for a, b in layout.bounds:
        for s0 in range(a, b - w + 1, w):
            level = float(np.mean(expected[s0 : s0 + w]))
            if level >= GATE_MIN_VARIANCE:
                means.append((s0, float(np.mean(power[s0 : s0 + w])) / level))
    if len(means) < 8:
        return None
    ref = float(np.median([v for _, v in means]))
    if ref <= 0:
        return None
    limit = ref * (1 + GATE_Z * math.sqrt(2.0 / (c * w)))
    for s0, v in means:
        if v > limit:
            flags[max(0, s0 - w) : s0 + 2 * w] = True
    if not flags.any() or flags.mean() > GATE_MAX_FRACTION:
        return None
    gate = (~flags).astype(float)
    ramp = 0.5 * (1 - np.cos(np.pi * np.arange(1, w + 1) / (w + 1)))
    edges = np.flatnonzero(np.diff(flags.astype(np.int8)))
    for e in edges:
        if flags[e + 1]:  # entering a gate: ramp down before it
            lo = max(0, e + 1 - w)
            gate[lo : e + 1] = np.minimum(gate[lo : e + 1], ramp[::-1][-(e + 1 - lo):])
        else:  # leaving a gate: ramp up after it
            hi = min(m, e + 1 + w)
            gate[e + 1 : hi] = np.minimum(gate[e + 1 : hi], ramp[: hi - e - 1])
    return gate


def _smoothed_spectrum(residual: np.ndarray, layout: Layout, fs: float, fraction: float,
                       coupled: bool = True, gate: np.ndarray | None = None,
                       cross: str = "coherence", debias: str = "off"):  # fmt: skip
    """Spline knots, per-channel spline coefficients (C, K), the band centres (B,) [Hz]
    and either the coherence bands ((B, C, C) unit-diagonal Hermitian; see the module
    docstring) or the regression bands (:func:`_regression_spectrum`): ``(knots, coefs,
    centres, coh, transfer)``, one of the last two None."""
    f, xf, pooling = _pooled_periodograms(residual, layout, fs, fraction, gate)
    knots = _knots(f)
    c = residual.shape[0]
    power = np.abs(xf) ** 2
    coefs = np.array([_whittle_spline(f, power[j], knots) for j in range(c)])
    if debias != "off":
        bias = np.ones_like(power)
        for _ in range(DEBIAS_ROUNDS):
            bias = _debias_factors(f, knots, coefs, pooling, fs, debias)
            coefs = np.array([_whittle_spline(f, power[j] / bias[j], knots) for j in range(c)])
        xf = xf / np.sqrt(bias)  # the cross-spectrum, from the corrected transforms
    if c == 1 or not coupled:
        return knots, coefs, np.array([f[0]]), np.eye(c, dtype=complex)[None], None
    if cross == "regression":
        return (knots, *_regression_spectrum(f, xf, knots, coefs))
    sd = np.exp(0.5 * (_design(np.log(f), knots) @ coefs.T)).T  # (C, F)
    stats = _cross_stats(xf / sd)
    centres, levels = [], []
    for lo, hi in band_edges(f, min_bins=32, per_decade=4):
        centres.append(math.exp(np.mean(np.log(f[lo:hi]))))
        levels.append(np.median(stats[:, lo:hi], axis=1) / _LN2)
    coh = _assemble(np.array(levels).T, c)
    coh = coh / np.sqrt(np.einsum("bii,bjj->bij", coh.real, coh.real))  # unit diagonal
    return knots, coefs, np.array(centres), _floor_psd(coh, 1e-3), None


#: How coupled channels' cross-spectrum is estimated (:meth:`NoiseModel.estimate`):
#: ``coherence`` (robust medians of the standardised channels' coherence per band; the
#: default) or ``regression`` (:func:`_regression_spectrum`: right for a shared red noise
#: source, but least squares also takes in a shared deterministic signal -- a clipped
#: accelerometer became six glitches -- and it costs 2x on such recordings).  Evidence:
#: docs/mismatch.md 9.21.
CROSS_KINDS = ("regression", "coherence")
CROSS_SPECTRUM = "coherence"
#: Passes of the regression's weighted least squares (weights: the innovation's PSD).
REGRESSION_PASSES = 3


def _interp_bands(f_hz: np.ndarray, centres: np.ndarray, bands: np.ndarray) -> np.ndarray:
    """(B, C, C) band values -> (F, C, C), linear in log f, held beyond the end bands."""
    lf = np.log(np.maximum(f_hz, centres[0]))
    lb = np.log(centres)
    flat = bands.reshape(bands.shape[0], -1)
    out = np.empty((np.size(f_hz), flat.shape[1]), complex)
    for k in range(flat.shape[1]):
        out[:, k] = np.interp(lf, lb, flat[:, k].real) + 1j * np.interp(lf, lb, flat[:, k].imag)
    return out.reshape(-1, *bands.shape[1:])


def _regression_spectrum(f: np.ndarray, xf: np.ndarray, knots: np.ndarray,
                         coefs: np.ndarray) -> tuple:  # fmt: skip
    """Cross-spectrum by sequential regression (the modified Cholesky form ``S = L D L^H``
    of Rosen & Stoffer, Biometrika 94, 335 (2007); Dai & Guo, Biometrika 91, 629 (2004)):
    channel j's transform is regressed on channels < j's in each quarter-decade band
    (weighted least squares, weights the inverse innovation PSD, bins that are a line in
    any channel left out), and the innovation ``X_j - sum_i B_ji X_i`` gets its own
    log-PSD spline.

    Why not a coherence per band: one red source seen by two channels (a 1/f force noise
    in both f_B-free rows) has a fixed transfer between them but a coherence that climbs
    towards 1 within the lowest band; a band's median coherence (0.95 on foreign 180077,
    where the lowest bins are ~1) leaves the source's power in the whitened difference
    channel, where any column carrying the same source correlates with it (docs 9.21).
    Least squares in a band puts its weight where the power is, so the transfer is right
    where an error would leak most.  Returns ``(innovation coefs (C, K), centres (B,),
    None, transfer (B, C, C))``."""
    c = xf.shape[0]
    design = _design(np.log(f), knots)
    marg = np.exp(design @ coefs.T).T  # (C, F) marginal PSDs
    clean = np.all(np.abs(xf) ** 2 < OUTLIER * marg, axis=0)
    bands = band_edges(f, min_bins=32, per_decade=4)
    centres = np.array([math.exp(np.mean(np.log(f[lo:hi]))) for lo, hi in bands])
    transfer = np.zeros((len(bands), c, c), complex)
    innov = coefs.copy()
    for j in range(1, c):
        var = marg[j]
        for _ in range(REGRESSION_PASSES):
            for k, (lo, hi) in enumerate(bands):
                keep = clean[lo:hi]
                if keep.sum() < 4 * j:
                    continue
                w = 1.0 / np.sqrt(var[lo:hi][keep])
                a = xf[:j, lo:hi][:, keep].T * w[:, None]
                transfer[k, j, :j] = np.linalg.lstsq(a, xf[j, lo:hi][keep] * w, rcond=None)[0]
            b = _interp_bands(f, centres, transfer)[:, j, :j]  # (F, j)
            e = xf[j] - np.einsum("fi,if->f", b, xf[:j])
            innov[j] = _whittle_spline(f, np.abs(e) ** 2, knots)
            var = np.exp(design @ innov[j])
    return innov, centres, None, transfer
