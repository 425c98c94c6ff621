"""Generic, unnamed features: what to say when no catalogue effect is the explanation.

The catalogue (:mod:`tmopt.mismatch.effects`) names physics.  A recording from a real
instrument will also hold physics the catalogue lacks -- a force step, a line at an
unrelated frequency, a curved bias change, a stiffness that jumps.  Without an
alternative, the stepwise selection names the catalogue effect that happens to absorb
part of such a feature (a step read as "glitch + bias drift"), and a flexible noise model
swallows the rest: a confident wrong name, the worst outcome.

So the selection also tests a few *shapes* with no physical name, on every axis, with
their search counted as trials (Bonferroni) and their searched parameters in the BIC
penalty, like any candidate:

* ``step`` -- a force ``H(t - t0)`` (onset searched);
* ``relaxation`` -- ``(1 - exp(-(t - t0)/tau)) H(t - t0)``: a force relaxing to a new
  level (onset and tau searched around the best steps);
* ``stiffness step`` -- ``x_a H(t - t0)``: the axis's stiffness changes at t0;
* ``curvature`` -- ``(t - t_mid)^2``: a bias that changes non-linearly (the catalogue's
  drift is linear);
* ``line`` -- a sinusoid at a searched frequency away from the excitation tones (2
  columns);
* ``nonlinear force`` -- the even and sign-odd terms of a force's Taylor/nonlinearity
  expansion that the catalogue lacks: ``x_a |x_a|`` and ``x_a^2`` (position), ``f_a |f_a|``
  (actuation).  The catalogue's only nonlinear term is ``k3 x^3``; under a multi-tone
  excitation each of these has its own harmonics and intermodulation lines (``x^2``:
  even harmonics and ``f_i +- f_j``; ``x|x|``: odd harmonics in other ratios than
  ``x^3``), so when one of them fits better than ``x^3`` the cubic name is not given;
* ``product`` -- ``x_a y_a`` on either axis of a test mass: a bilinear coupling, lines at
  ``f_x +- f_y`` that neither a linear cross-coupling (lines at ``f_y``) nor a smooth
  noise spectrum has.

When one of them explains the residual better (larger delta-BIC) than every catalogue
effect, it enters the model -- so the residual is cleaned and the search goes on -- but it
is reported as **unexplained**, with what and where ("a step in the force on x1 at t =
812 s"), never under a catalogue name.  A catalogue effect whose signature is the shape
(a full-record linear drift vs a curvature, a glitch vs a step) keeps the smaller BIC
penalty, so the catalogue wins where it fits.
"""

from __future__ import annotations

import math

import numpy as np

from tmopt.mismatch.effects.base import TMS, Candidate, Context
from tmopt.mismatch.fit import AXES, Column, axis_column, kinematic_series, tone_part

__all__ = ["GENERIC", "candidates", "shape_rivals", "N_ONSETS", "NONLINEAR_KINDS"]

#: The unnamed features' label in candidates and reports.
GENERIC = "unexplained"
#: The nonlinear and product forces (:func:`_nonlinear`, :func:`_products`): their lines
#: (harmonics, intermodulation, ``f_x +- f_y``) on an axis are partly what a linear
#: two-axis coupling of that axis fits (report rival, docs/mismatch.md 9.10).
X_ABS, X_SQUARED, F_ABS, XY_PRODUCT = "x|x| force", "x^2 force", "f|f| actuation", "x*y product"
NONLINEAR_KINDS = (X_ABS, X_SQUARED, F_ABS, XY_PRODUCT)
#: Onsets on the coarse grid (5 %..95 % of the record), then refined between neighbours.
N_ONSETS = 48
N_REFINE = 9


def _stat(e: np.ndarray, t: np.ndarray) -> float:
    energy = float(np.sum(t**2))
    return float(np.sum(e * t)) ** 2 / energy if energy > 0 else 0.0


def _onset_search(ctx: Context, shape, base=None,
                  axes=range(4)) -> list[tuple[float, int, float]]:  # fmt: skip
    """Best onset per axis (of ``axes``) of a one-column template ``shape(axis, t0)``
    (series (N,)): (statistic, axis, t0).  With :data:`FINE_ONSETS` and ``base``
    (``base(axis)``: the series the step multiplies, so that ``shape(a, t0) = base(a)
    H(t - t0)``) the onset is then searched at every sample and between samples
    (:func:`_fine_onset`)."""
    d = ctx.data
    e = ctx.eq_noise.whiten(ctx.eq_residual)
    t_lo, t_hi = d.time[0], d.time[-1]
    grid = t_lo + (t_hi - t_lo) * np.linspace(0.05, 0.95, N_ONSETS)
    step = grid[1] - grid[0]
    out = []
    for a in axes:
        best = (-1.0, grid[0])
        energy = []
        for t0 in grid:
            w = ctx.eq_noise.whiten(axis_column(ctx.basis, a, shape(a, t0)))
            energy.append(float(np.sum(w**2)))
            lam = _stat(e, w)
            if lam > best[0]:
                best = (lam, t0)
        for t0 in best[1] + step * np.linspace(-1, 1, N_REFINE):
            if not t_lo < t0 < t_hi:
                continue
            lam = _stat(e, ctx.eq_noise.whiten(axis_column(ctx.basis, a, shape(a, t0))))
            if lam > best[0]:
                best = (lam, float(t0))
        if FINE_ONSETS and base is not None:
            best = max(best, _fine_onset(ctx, e, a, shape, base(a), grid, np.array(energy)))
        out.append((best[0], a, float(best[1])))
    return out


#: Onsets of the step features searched at every sample and between samples (round r7
#: study, docs/mismatch.md 9.10): under a steep coloured noise model a whitened step is
#: nearly a spike at its onset, and its statistic falls from 1644 at the true onset to 57
#: three seconds off (foreign 50112; a stiffness step, foreign 40131: 3301 to 3.4), while
#: the coarse grid is ~10-40 s apart -- the step feature never competed and a glitch with a
#: 362 s decay plus a drift took its place.  On since stop 37: paired on 300 never-seen
#: recordings (110000+, docs/mismatch.md 9.7 "Twelfth run") it changed 9, none for the
#: worse that the data could tell (wrong names 8 -> 5, no false alarm, no attribution lost).
FINE_ONSETS = True
#: Sub-sample onsets tried between two samples (the force averaged over each sample).
N_FRACTIONS = 8
#: Best approximate onsets per axis re-evaluated exactly.
N_FINE_PEAKS = 3


def _adjoint_whiten(noise, arr: np.ndarray) -> np.ndarray:
    """``W' arr`` for ``W`` = ``noise.whiten`` (per segment: taper, transform, the
    per-frequency factor, back; its adjoint takes the conjugate-transposed factor and the
    taper last).  Used to search onsets only; the statistic is recomputed with ``whiten``."""
    from tmopt.mismatch.noise_model import taper

    if noise.kind == "white" and not noise.red:
        return np.linalg.solve(np.linalg.cholesky(noise.cov).T, arr)
    out = np.zeros(arr.shape)
    for a, b in noise.layout.bounds:
        m = b - a
        win = taper(m, noise.taper_fraction) if noise.tapered else np.ones(m)
        yf = np.fft.rfft(arr[:, a:b], axis=1)
        xf = np.einsum("fji,jf->if", noise._whitener(m).conj(), yf)
        out[:, a:b] = np.fft.irfft(xf, n=m, axis=1) * win
    return out


def _fine_onset(ctx: Context, e: np.ndarray, a: int, shape, base: np.ndarray,
                grid: np.ndarray, energy: np.ndarray) -> tuple[float, float]:
    """Best onset of ``base H(t - t0)`` on axis ``a`` at sample resolution and between
    samples: the matched statistic's numerator at every sample onset is a reverse
    cumulative sum of ``base x (N' W' e)`` (exact, one adjoint whitening), its
    denominator interpolated from the coarse grid's ``energy``; the best
    :data:`N_FINE_PEAKS` are re-evaluated exactly with ``shape`` at :data:`N_FRACTIONS`
    sub-sample onsets before each.  ``(statistic, t0)``."""
    d = ctx.data
    t, h = d.time, d.dt
    g = ctx.basis[a] @ _adjoint_whiten(ctx.eq_noise, e)
    num = np.cumsum((base * g)[::-1])[::-1]
    approx = num**2 / np.maximum(np.interp(t, grid, energy), 1e-300)
    inside = (t > grid[0] - (grid[1] - grid[0])) & (t < grid[-1] + (grid[1] - grid[0]))
    approx[~inside] = 0.0
    best = (-1.0, float(t[0]))
    taken: list[int] = []
    for n in np.argsort(approx)[::-1]:
        if len(taken) >= N_FINE_PEAKS:
            break
        if any(abs(int(n) - k) < 8 for k in taken):
            continue
        taken.append(int(n))
        for frac in np.arange(N_FRACTIONS) / N_FRACTIONS:
            t0 = float(t[n] - frac * h)
            lam = _stat(e, ctx.eq_noise.whiten(axis_column(ctx.basis, a, shape(a, t0))))
            if lam > best[0]:
                best = (lam, t0)
    return best


def _onset_candidates(ctx: Context, kind: str, shape, words: str,
                      found=None, trials: float | None = None) -> list[Candidate]:  # fmt: skip
    """The best of an onset search of ``shape`` (``found``: its result, else searched;
    ``trials``: its onsets tried, by default every axis' :func:`_onset_trials`)."""
    if found is None:
        found = _onset_search(ctx, shape)
    lam, a, t0 = max(found)
    if lam <= 0:
        return []
    trials = _onset_trials(ctx.data.n) if trials is None else trials
    col = Column(f"{GENERIC}:{kind}[{AXES[a]}]", axis_column(ctx.basis, a, shape(a, t0)))
    return [Candidate(GENERIC, AXES[a], "equation", [kind], ["-"], [col], None,
                      trials=trials, fixed={"feature": kind, "t0_s": t0},
                      n_searched=1,
                      text=words.format(ch=AXES[a], where=TMS[AXES[a]], t0=t0))]  # fmt: skip


def _step_shape(t: np.ndarray, h: float, t0: float) -> np.ndarray:
    """``H(t - t0)``; with :data:`FINE_ONSETS` averaged over each sample ``[t_n, t_n + h)``
    (equal to the sampled step when ``t0`` is a sample time), so an onset between samples
    has its fractional first sample."""
    if FINE_ONSETS:
        return np.clip((t + h - t0) / h, 0.0, 1.0)
    return (t >= t0).astype(float)


def _onset_trials(n: int) -> float:
    """Onsets tried per axis: the coarse grid and its refinement, and with
    :data:`FINE_ONSETS` every sample times the sub-sample fractions."""
    return 4.0 * (N_ONSETS + N_REFINE + (n * N_FRACTIONS if FINE_ONSETS else 0))


def _steps(ctx: Context, axis: int | None = None) -> list[Candidate]:
    """The best lasting force step, and the best relaxation around the steps found: on
    every axis, onsets to a sample; with ``axis``, on that one only and on the coarse
    grid (:func:`shape_rivals`)."""
    t, h = ctx.data.time, ctx.data.dt

    def step(a: int, t0: float) -> np.ndarray:
        return _step_shape(t, h, t0)

    if axis is None:
        found, trials = _onset_search(ctx, step, lambda a: np.ones(t.size)), None
    else:
        found, trials = _onset_search(ctx, step, axes=[axis]), N_ONSETS + N_REFINE
    return _onset_candidates(
        ctx, "step", step,
        "unexplained: a lasting step of the force on {ch} ({where}) at t = {t0:.1f} s "
        "(no catalogue effect is a step)", found, trials) + \
        _relaxations(ctx, found, 4 if axis is None else 1)  # fmt: skip


#: Relaxation times searched [s] (thermal and charging relaxations of LPF: minutes to
#: about an hour; longer ones are drifts over these records), and onsets before the best
#: step's, in units of the relaxation time (a relaxation's best-fitting step comes later
#: than its onset).
RELAX_TAUS = (30.0, 60.0, 120.0, 250.0, 500.0, 1000.0)
RELAX_LEADS = np.linspace(0.0, 1.5, 7)
#: Axes (best step statistic first) on which the relaxation is searched.
RELAX_AXES = 2


def _relaxations(ctx: Context, found: list[tuple[float, int, float]],
                 n_axes: int = 4) -> list[Candidate]:  # fmt: skip
    """A force that relaxes to a new level, ``(1 - exp(-(t - t0)/tau)) H(t - t0)`` (a
    thermal or charging relaxation; the step is its tau -> 0 limit): onset and tau searched
    around the best step onsets ``found`` (:func:`_onset_search`) of the ``RELAX_AXES``
    best axes.  Several glitches in a row or a glitch and a drift otherwise stand in for
    it under catalogue names."""
    d = ctx.data
    t = d.time
    e = ctx.eq_noise.whiten(ctx.eq_residual)
    best = (-1.0, 0, 0.0, 0.0)
    for _, a, ts in sorted(found, reverse=True)[:RELAX_AXES]:
        for tau in RELAX_TAUS:
            for lead in RELAX_LEADS:
                t0 = ts - lead * tau
                if not t[0] < t0 < t[-1]:
                    continue
                shape = -np.expm1(-np.maximum(t - t0, 0.0) / tau)
                lam = _stat(e, ctx.eq_noise.whiten(axis_column(ctx.basis, a, shape)))
                if lam > best[0]:
                    best = (lam, a, float(t0), tau)
    lam, a, t0, tau = best
    if lam <= 0:
        return []
    shape = -np.expm1(-np.maximum(t - t0, 0.0) / tau)
    col = Column(f"{GENERIC}:relaxation[{AXES[a]}]", axis_column(ctx.basis, a, shape))
    trials = n_axes * (N_ONSETS + N_REFINE) * len(RELAX_TAUS) * len(RELAX_LEADS)
    return [Candidate(GENERIC, AXES[a], "equation", ["relaxation"], ["m s^-2"], [col], None,
                      trials=trials, n_searched=2,
                      fixed={"feature": "relaxation", "t0_s": t0, "tau_s": tau},
                      text=f"unexplained: the force on {AXES[a]} ({TMS[AXES[a]]}) relaxes to "
                           f"a new level from t = {t0:.1f} s with time constant ~{tau:.0f} s "
                           "(no catalogue effect is a lasting exponential change)")]  # fmt: skip


def shape_rivals(ctx: Context, axis: str, stiffness: bool = False) -> list[Candidate]:
    """The searched shapes that a selected *linear* change in time on ``axis`` must not
    need (:meth:`~tmopt.mismatch.effects.base.Effect.shape_search`): the best lasting
    step and relaxation of the force on that axis (:func:`_steps`), or with ``stiffness``
    the best stiffness step (:func:`_stiffness_steps`).  Their onsets only on the coarse
    grid of that one axis (a check needs the shape's significance, not its onset to a
    sample), so each carries its own grid as trials: :data:`N_ONSETS` + :data:`N_REFINE`
    onsets, times the relaxation's taus and leads.

    Why searched: Legendre P2 + P3 (the fixed half) see a step or a relaxation only
    through its projection on two smooth shapes; a relaxation 60 % into the record, named
    a drift (benchmark 150000: f150132, k150133, ``distinct`` 16.8 and 18.8), left P2 + P3
    at p 0.02, while the relaxation itself beside the drift reached a GLR of 28."""
    if ctx.eq_residual is None or ctx.eq_noise is None or ctx.data.n < 64:
        return []
    a = AXES.index(axis)
    return _stiffness_steps(ctx, a) if stiffness else _steps(ctx, a)


def _stiffness_steps(ctx: Context, axis: int | None = None) -> list[Candidate]:
    """The best stiffness step ``x_a H(t - t0)``: on every axis, onsets to a sample; with
    ``axis``, on that one only and on the coarse grid (:func:`shape_rivals`)."""
    t, x, h = ctx.data.time, ctx.data.x_eq, ctx.data.dt

    def shape(a: int, t0: float) -> np.ndarray:
        return x[a] * _step_shape(t, h, t0)

    if axis is None:
        found, trials = _onset_search(ctx, shape, lambda a: x[a]), None
    else:
        found, trials = _onset_search(ctx, shape, axes=[axis]), N_ONSETS + N_REFINE
    return _onset_candidates(
        ctx, "stiffness step", shape,
        "unexplained: the stiffness of {ch} ({where}) changes abruptly at t = {t0:.1f} s "
        "(the catalogue's stiffness drift is linear)", found, trials)  # fmt: skip


def _curvatures(ctx: Context) -> list[Candidate]:
    d = ctx.data
    tc = d.centred_time
    span = max(float(np.ptp(d.time)), d.dt)
    series = (tc / span) ** 2
    out = []
    for a in range(4):
        col = Column(f"{GENERIC}:curvature[{AXES[a]}]", axis_column(ctx.basis, a, series))
        out.append(Candidate(GENERIC, AXES[a], "equation", ["curvature"], ["m s^-2"], [col],
                             None, fixed={"feature": "curvature"},
                             null="curvature",
                             text=f"unexplained: the force on {AXES[a]} ({TMS[AXES[a]]}) "
                                  "changes non-linearly in time (a curved bias; the "
                                  "catalogue's drift is linear)"))  # fmt: skip
    return out


def _lines(ctx: Context, refine: bool = False) -> list[Candidate]:
    """The strongest line on any axis away from the excitation tones (+-2 bins): whitened
    periodogram of the longest segment projected on each axis's whitened direction;
    ``refine``: its frequency then read off the whole record (:func:`_refined_frequency`),
    the trials counted on that finer grid (:data:`LINE_REFINE_STEPS`)."""
    d = ctx.data
    a0, b0 = d.longest.start, d.longest.stop
    m = b0 - a0
    if m < 64:
        return []
    noise = ctx.eq_noise
    from tmopt.mismatch.noise_model import taper

    win = taper(m, noise.taper_fraction) if noise.tapered else np.ones(m)
    f = np.fft.rfftfreq(m, d.dt)
    xw = np.einsum("fij,jf->if", noise._whitener(m), np.fft.rfft(ctx.eq_residual[:, a0:b0] * win,
                                                                 axis=1))  # fmt: skip
    dirs = np.einsum("fij,ja->fia", noise._whitener(m), ctx.basis.T)  # (F, 2, 4)
    dirs = dirs / np.maximum(np.linalg.norm(dirs, axis=1, keepdims=True), 1e-300)
    proj = np.abs(np.einsum("fia,if->af", np.conj(dirs), xw)) ** 2 * 2 / float(np.sum(win**2))
    ok = np.ones(f.size, bool)
    ok[:3] = False
    df = f[1] - f[0]
    tones = {t for ax in range(4) for t in d.tones(ax)}
    for t0 in tones:
        ok &= np.abs(f - t0) > 2.5 * df
    if not ok.any():
        return []
    proj[:, ~ok] = 0.0
    a, k = np.unravel_index(int(np.argmax(proj)), proj.shape)
    f0 = float(f[k])
    tt = d.time - d.time[0]
    trials = 4.0 * float(ok.sum())
    if refine:
        f0, span = _refined_frequency(ctx, a, f0, df, tt)
        trials *= max(1.0, span * df)  # independent frequencies: 1/span apart, not df
    cols = [Column(f"{GENERIC}:line[{AXES[a]}]{j}",
                   axis_column(ctx.basis, a, fn(2 * math.pi * f0 * tt)))
            for j, fn in enumerate((np.sin, np.cos))]  # fmt: skip
    return [Candidate(GENERIC, AXES[a], "equation", ["line_sin", "line_cos"], ["m s^-2"] * 2,
                      cols, None, trials=trials,
                      fixed={"feature": "line", "frequency_hz": f0}, n_searched=1,
                      text=f"unexplained: a force line at {f0:.5g} Hz on {AXES[a]} "
                           f"({TMS[AXES[a]]}), unrelated to the excitation tones")]  # fmt: skip


#: Read a line's frequency off the whole record (``Settings.line_refine``; docs/mismatch.md
#: 9.38).  The search's grid is the longest gap-free segment's periodogram, df = 1/T_seg;
#: the line's columns span the whole record, T.  Where gaps cut the record, a line between
#: two grid frequencies keeps its phase over T only at its own frequency: off by df/2 it
#: loses most of its power (kernel 370108: a 4.175 mHz force line of `visible` 44.5
#: placed at 4.428 mHz, GLR 13.0 -- nothing reported).
LINE_REFINE_STEPS = 4  # grid points per 1/T (a quarter cycle over the record at most)
#: On by default since stop 63 (9.38's paired test); ``Settings.line_refine``'s default.
LINE_REFINE = True


def _refined_frequency(ctx: Context, a: int, f0: float, df: float,
                       tt: np.ndarray) -> tuple[float, float]:  # fmt: skip
    """The frequency within ``f0 +- df`` whose sinusoid on axis ``a`` (whitened, both
    phases) takes the most of the whitened equation residual, on a grid 1/(4 span) --
    and the span [s]; ``tt`` (N,): the record's times from its start."""
    white = ctx.eq_noise.whiten
    span = float(tt[-1]) + ctx.data.dt
    r = white(ctx.eq_residual).ravel()
    n = max(2, int(math.ceil(2.0 * df * span * LINE_REFINE_STEPS)) + 1)
    best = (-1.0, f0)
    for fq in np.linspace(max(f0 - df, df), f0 + df, n):
        x = np.column_stack([white(axis_column(ctx.basis, a, fn(2 * math.pi * fq * tt))).ravel()
                             for fn in (np.sin, np.cos)])  # fmt: skip
        coef, *_ = np.linalg.lstsq(x, r, rcond=None)
        best = max(best, (float(r @ (x @ coef)), float(fq)))
    return best[1], span


def _series_candidate(ctx: Context, a: int, kind: str, series: np.ndarray, unit: str,
                      text: str) -> Candidate:  # fmt: skip
    col = Column(f"{GENERIC}:{kind}[{AXES[a]}]", axis_column(ctx.basis, a, series))
    return Candidate(GENERIC, AXES[a], "equation", [kind], [unit], [col], None,
                     fixed={"feature": kind},
                     text=f"unexplained: {text} on {AXES[a]} ({TMS[AXES[a]]})")  # fmt: skip


def _nonlinear(ctx: Context) -> list[Candidate]:
    """``x|x|``, ``x^2`` and ``f|f|`` per axis (about the readout's zero, the housing's
    centre, as the catalogue's ``x^3``)."""
    d = ctx.data
    out = []
    for a in range(4):
        x, f = d.x_eq[a], d.force[a]
        out += [
            _series_candidate(ctx, a, X_ABS, x * np.abs(x), "m^-1 s^-2",
                              "a nonlinear force kappa x|x| (not the catalogue's cubic)"),
            _series_candidate(ctx, a, X_SQUARED, x**2, "m^-1 s^-2",
                              "a quadratic (even) stiffness term x^2"),
            _series_candidate(ctx, a, F_ABS, f * np.abs(f), "s^2 m^-1",
                              "a nonlinear actuation term f|f|"),
        ]  # fmt: skip
    return out


def _products(ctx: Context) -> list[Candidate]:
    """``x y`` of one test mass on either of its axes."""
    d = ctx.data
    out = []
    for a, b in ((0, 2), (1, 3)):  # (x1, y1), (x2, y2)
        xy = d.x_eq[a] * d.x_eq[b]
        for on in (a, b):
            out.append(_series_candidate(ctx, on, XY_PRODUCT, xy, "m^-1 s^-2",
                                         f"a bilinear coupling {AXES[a]}*{AXES[b]} (lines at "
                                         "f_x +- f_y)"))  # fmt: skip
    return out


#: A kinematic-group shape (:func:`_readout_timings`): the unnamed shapes were all forces,
#: so a displacement readout stamped late (a sub-sample timing offset) went unseen or
#: under a cross-talk's name (f/k90138-140, f/k110140: ``distinct`` 21-60 beside it).
READOUT_TIMING = True
TIMING = "readout timing"
#: The readout timing feature's regressor (``Settings.timing_regressor``): ``"tones"``,
#: the accelerometer term's excitation-tone part differentiated tone by tone, or
#: ``"band"``, the measured term's central difference low-passed below the excitation's
#: band (:func:`band_derivative`).  The first is what the tool shipped with; the second
#: also carries the motion the noise drives below that band, where most of a late stamp's
#: signature can lie (340140: 18 of its distinct SNR 20 outside the tone part), and
#: leaves out the loop's band, where the measured term is endogenous (docs/mismatch.md 9.34).
TIMING_REGRESSORS = ("tones", "band")
TIMING_DEFAULT = "tones"
#: ``"band"``'s cutoff in units of the highest excitation tone of any axis, and its cap in
#: units of the sample rate (the loop's band starts above the excitation's; docs 9.34).
BAND_OVER_TONES = 1.5
BAND_CAP = 0.25
#: Order of the zero-phase Butterworth low-pass (run forward and back: twice this).
BAND_ORDER = 4


def central_derivative(series: np.ndarray, rows: np.ndarray, dt: float) -> np.ndarray:
    """``(s[i+1] - s[i-1]) / (2 dt)`` of a series on the kinematic rows ``rows`` (sample
    indices, (R,)), 0 where row i's neighbours are not the adjacent samples (a segment's
    edge).  Antisymmetric, so under no effect it is in quadrature with any stationary
    noise that enters the residual undifferentiated (the accelerometer's own noise)."""
    out = np.zeros_like(series)
    inner = (rows[2:] - rows[1:-1] == 1) & (rows[1:-1] - rows[:-2] == 1)
    out[1:-1][inner] = (series[2:][inner] - series[:-2][inner]) / (2.0 * dt)
    return out


def band_cutoff(tones: list[float], fs: float) -> float:
    """``"band"``'s cutoff [Hz]: :data:`BAND_OVER_TONES` times the highest excitation tone
    ``tones`` (every axis's, [Hz]), at most :data:`BAND_CAP` times ``fs``."""
    return min(BAND_OVER_TONES * max(tones), BAND_CAP * fs)


def band_derivative(series: np.ndarray, rows: np.ndarray, bounds, dt: float,
                    cutoff: float) -> np.ndarray:  # fmt: skip
    """:func:`central_derivative` low-passed below ``cutoff`` [Hz] by a zero-phase
    Butterworth filter within each kinematic segment (``bounds``: the rows' ``(start,
    stop)`` per segment, ``Data.kin_layout``); a segment too short to filter is left 0.

    Why: the measured accelerometer term holds the loop's response to the readout noise,
    which the kinematic residual also holds.  Read by the profile likelihood (the noise
    model estimated again under it) the unfiltered difference took that band in on clean
    recordings (clean kernel 37560: ratio 2869; clean foreign 340007: a fitted "timing" of
    0.25 s at h = 0.4 s, docs 9.34).  Below the excitation's band the motion is the
    excitation's and the noise's, not the loop's reply to the readout."""
    from scipy import signal

    d = central_derivative(series, rows, dt)
    sos = signal.butter(BAND_ORDER, cutoff, fs=1.0 / dt, output="sos")
    pad = 3 * (2 * len(sos) + 1)
    out = np.zeros_like(d)
    for lo, hi in bounds:
        if hi - lo > pad:
            out[lo:hi] = signal.sosfiltfilt(sos, d[lo:hi], padlen=pad)
    return out


def _readout_timings(ctx: Context, regressor: str = TIMING_DEFAULT) -> list[Candidate]:
    """A displacement readout stamped ``tau`` late, ``x_meas(t) = x(t - tau)``, per excited
    axis: to first order in tau its exact-ZOH kinematic residual (:func:`kinematic_target`)
    is ``-tau d/dt`` of the second difference of x, i.e. of the accelerometer term
    ``g (a_n + a_(n-1))`` (:func:`kinematic_series`).  ``regressor``
    (:data:`TIMING_REGRESSORS`): ``"tones"``, that term's excitation-tone part
    differentiated tone by tone (the tones are set by the reference, so it is its own
    instrument -- the closed loop puts readout noise into ``acc`` -- and it is in
    quadrature with a readout scale's, the same tone part undifferentiated); ``"band"``,
    the measured term's derivative below the excitation's band (:func:`band_derivative`),
    which also holds the motion the noise drives there.  Both are referred to the timing
    null (``calibration.LOWFREQ_NULL["timing"]``)."""
    if regressor not in TIMING_REGRESSORS:
        raise ValueError(f"regressor must be one of {TIMING_REGRESSORS}; got {regressor!r}")
    d = ctx.data
    rows = d.kin_index
    every = [f for a in range(4) for f in d.tones(a)]
    out = []
    for a in range(4):
        tones = d.tones(a)
        if not tones:
            continue
        arr = np.zeros((4, rows.size))
        series = kinematic_series(d, a)
        arr[a] = -(tone_part(series, d.time[rows], tones, derivative=True)
                   if regressor == "tones" else band_derivative(
                       series, rows, d.kin_layout.bounds, d.dt, band_cutoff(every, d.fs)))
        col = Column(f"{GENERIC}:{TIMING}[{AXES[a]}]", arr, None, (), a)
        out.append(Candidate(GENERIC, f"{AXES[a]} readout", "kinematic", ["tau"], ["s"],
                             [col], None, fixed={"feature": TIMING}, null="timing",
                             text=f"unexplained: the displacement readout of {AXES[a]} "
                                  f"({TMS[AXES[a]]}) is out of step with its accelerometer "
                                  "(a timing offset: the residual is in quadrature with "
                                  "the motion; no catalogue effect delays a readout)"))
    return out


def candidates(ctx: Context, timing: str = TIMING_DEFAULT,
               line_refine: bool = LINE_REFINE) -> list[Candidate]:  # fmt: skip
    """The generic features' best variants for this residual (see the module docstring);
    ``timing``: the readout timing feature's regressor (:data:`TIMING_REGRESSORS`);
    ``line_refine``: the line's frequency read off the whole record (:func:`_lines`)."""
    if ctx.eq_residual is None or ctx.eq_noise is None or ctx.data.n < 64:
        return []
    return (_steps(ctx) + _stiffness_steps(ctx) + _curvatures(ctx) + _lines(ctx, line_refine)
            + _nonlinear(ctx) + _products(ctx)
            + (_readout_timings(ctx, timing) if READOUT_TIMING else []))  # fmt: skip
