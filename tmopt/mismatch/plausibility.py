"""Is this a closed-loop recording the diagnosis can speak about?  (Issue 20, part 4.)

The diagnosis compares a recording with the model of a closed loop.  Nonsense input --
white noise in every channel, a constant or all-zero channel, shuffled samples, swapped
channels, a few seconds of data -- must not be "explained" by physical effects, nor get a
confident "no significant mismatch".  Before any fit, :func:`precheck` tests the loop's
own consistency, channel by channel, with tests that need no model of the controller or
the noise levels:

* **enough data**: at least :data:`MIN_SAMPLES` samples in gap-free segments (the noise
  model needs Welch pieces and bands; the locate step needs windows);
* **live channels**: no displacement, acceleration or force channel is constant (a dead
  sensor, a filler value, a noise-free simulation: nothing to test against);
* **excitation**: some axis carries excitation lines (the identification needs them;
  shuffled samples have none);
* **force vs acceleration** (Eq. 10): in the f_B-free combinations the measured
  acceleration follows the commanded force with slope 1 (``acc - f = k x + f_D - P f_B +
  noise``); a slope measurably far from 1 (beyond any plausible gain error) means the
  channels do not belong together;
* **displacement vs acceleration** (kinematics): at the excitation tones of an excited
  axis the readout's second difference equals ``h^2`` times the acceleration (slope 1,
  instrumental variables as in the kinematic group);
* **force vs displacement** (causality of the controller): the commanded force of a
  closed loop is a causal function of past readouts; a low-order linear model
  ``f_n ~ f_{n-1}, f_{n-2}, e_n, e_{n-1}, e_{n-2}`` (e = reference - readout) fitted in
  short windows (adaptive gains allowed) explains most of its variance on some axis.  If
  no axis shows this, the data are not a closed loop (or are shuffled);
* **each axis's own loop**: the force of each axis follows *its own* readout.  The
  controller feeds the readout (and its noise) into the force; in short windows, the
  readout's lags ``x_n, x_{n-1}, x_{n-2}`` must add significantly (F-test) to what the
  force's own past and the axis's reference explain.  A shuffled readout adds nothing; a
  swapped one is followed by the *other* axis's force.  The test compares each axis with
  the recording's own other axes, so it needs no controller gains or noise levels.

Each test gives ``ok`` (verified), ``unknown`` (cannot tell: e.g. no motion) or
``fail``; any ``fail``, or no positive evidence of a closed loop at all, refuses the
recording with "cannot diagnose: <why>".  After the fit, :func:`implausible_effects`
refuses explanations whose size is beyond physics (a "readout scale" of 999 is a unit
error, not a calibration error).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tmopt.mismatch.fit import AXES, Data, null_basis, tone_instrument

__all__ = ["MIN_SAMPLES", "Check", "Verdict", "precheck", "implausible_effects",
           "loop_attribution", "saturations", "rail_samples",
           "check_fragmentation", "FRAGMENT_SAMPLES", "beyond_physics", "STIFFNESS_LIMIT"]

#: A measured channel (accelerometer or readout) is saturated -- an ADC at its rail -- when
#: at least RAIL_MIN of its samples hold exactly its largest (or smallest) value and that
#: value holds at least RAIL_RATIO times as many samples as any value away from the
#: extremes.  Physics, not a fit: a continuous reading repeats a value with probability 0,
#: a uniformly quantised one holds fewest samples in its outermost codes (the tails of its
#: distribution), while a clip piles every sample beyond the level onto one value.  Null
#: on development recordings: docs/mismatch.md 9.10.
RAIL_MIN = 10
RAIL_RATIO = 10

#: Fewest samples (in gap-free segments) a diagnosis accepts.
MIN_SAMPLES = 256
#: A slope of acc on force (or of d2x on h^2 acc) further than this from 1 is not a gain
#: or scale error (the catalogue's plausible magnitudes are <= 5 %, its range <= 50 %).
SLOPE_TOLERANCE = 0.5
#: ... and it must be this many standard errors away (a measured, not a noisy, slope).
SLOPE_Z = 6.0
#: A slope known to this standard error verifies the relation.
SLOPE_SE_OK = 0.1
#: Windowed R^2 of the causal controller model: above it the force follows the readouts.
LOOP_R2_OK = 0.5
CONTROLLER_WINDOW = 64
#: Per-window F-test level of "the force depends on this readout" ...
FOLLOW_P = 0.01
#: ... and the fraction of windows that must pass it: under "no dependence" about FOLLOW_P
#: of them do (binomially), under a closed loop nearly all; one half separates the two
#: by many standard errors for the >= 4 windows a minimal recording has.
FOLLOW_FRACTION = 0.5
#: Windows per axis pair for the per-axis loop test (spread over the record).
FOLLOW_WINDOWS = 100


@dataclass
class Check:
    name: str
    status: str  # "ok" | "unknown" | "fail"
    detail: str
    values: dict = field(default_factory=dict)


@dataclass
class Verdict:
    checks: list[Check]
    reason: str | None = None  # None: the recording may be diagnosed

    @property
    def refused(self) -> bool:
        return self.reason is not None

    def as_dict(self) -> dict:
        return {"refused": self.refused, "reason": self.reason,
                "checks": [{"name": c.name, "status": c.status, "detail": c.detail,
                            **({"values": c.values} if c.values else {})}
                           for c in self.checks]}  # fmt: skip


def _slope(y: np.ndarray, x: np.ndarray, z: np.ndarray | None = None) -> tuple[float, float]:
    """IV (or OLS when ``z`` is None) slope of y on x with its standard error."""
    z = x if z is None else z
    zx = float(z @ x)
    if zx == 0 or not math.isfinite(zx):
        return math.nan, math.inf
    b = float(z @ y) / zx
    r = y - b * x
    se = math.sqrt(float(np.mean(r**2)) * float(z @ z)) / abs(zx)
    return b, se


def _demean(v: np.ndarray) -> np.ndarray:
    return v - v.mean(axis=-1, keepdims=True)


def rail_mask(v: np.ndarray) -> tuple[np.ndarray, list[float]]:
    """Samples of ``v`` at a saturated rail (:data:`RAIL_MIN`, :data:`RAIL_RATIO`) and the
    rail levels; an empty list when ``v`` has none."""
    mask = np.zeros(v.size, bool)
    if v.size == 0 or not np.all(np.isfinite(v)) or float(np.ptp(v)) == 0.0:
        return mask, []
    ends = {float(np.max(v)), float(np.min(v))}
    at = {e: v == e for e in ends}
    inner = ~np.logical_or.reduce(list(at.values()))
    _, counts = np.unique(v[inner], return_counts=True)
    other = max(int(counts.max()) if counts.size else 0, 1)
    levels = []
    for e, m in at.items():
        k = int(m.sum())
        if k >= RAIL_MIN and k >= RAIL_RATIO * other:
            mask |= m
            levels.append(e)
    return mask, sorted(levels)


def saturations(data: Data) -> list[dict]:
    """Measured channels pinned at a rail (an ADC saturating: the recorded value is the
    rail, not the measurement): ``{"channel", "axis", "levels", "samples", "fraction"}``.
    The commanded forces are not judged (a command limited at its range is what was
    applied, and the model reads it as recorded)."""
    out = []
    for kind, arr in (("acc_", data.acc), ("", data.x)):
        for a, name in enumerate(AXES):
            if not arr.shape[1]:
                continue
            mask, levels = rail_mask(arr[a])
            if levels:
                out.append({"channel": f"{kind}{name}", "axis": name, "levels": levels,
                            "samples": int(mask.sum()), "fraction": float(mask.mean())})
    return out


def rail_samples(data: Data) -> np.ndarray:
    """(N,) True where any measured channel sits at its rail (:func:`rail_mask`): the
    samples :func:`tmopt.mismatch.diagnose.diagnose` leaves out as gaps."""
    out = np.zeros(data.n, bool)
    for arr in (data.acc, data.x):
        for row in arr:
            out |= rail_mask(row)[0]
    return out


def check_saturation(data: Data) -> Check:
    """Saturated measured channels (:func:`saturations`) are reported, never refused: the
    samples at a rail are left out of the force-vs-acceleration check, and the diagnosis
    reports the channel unexplained (no name is more than part of the story there)."""
    sat = saturations(data)
    if not sat:
        return Check("saturation", "ok", "no measured channel sits at a rail")
    return Check("saturation", "unknown", "; ".join(
        f"{s['channel']} saturates: {s['samples']} samples ({s['fraction']:.1%}) exactly at "
        + " / ".join(f"{v:.4g}" for v in s["levels"]) for s in sat), {"saturated": sat})


def check_length(data: Data) -> Check:
    n = data.n
    if n < MIN_SAMPLES:
        rec = data.usage.get("samples_recorded", n)
        return Check("enough data", "fail",
                     f"only {n} usable samples (of {rec} recorded, in gap-free segments of "
                     f">= 64); the noise model and the tests need at least {MIN_SAMPLES}",
                     {"samples_used": n})  # fmt: skip
    return Check("enough data", "ok", f"{n} samples in {len(data.segments)} segment(s)")


#: A record cut into gap-free segments of median length below FRAGMENT_SAMPLES is flagged
#: (:func:`check_fragmentation`): on clean flight-like recordings cut by random gaps the
#: false alarms were 7/36 with the median segment below 256 samples, 1/28 at 256-511 and
#: 1/86 at 512 or more (``experiments/mismatch_gap_calibration.py``, docs/mismatch.md
#: 9.22), and on held-out seeds 20/88, 3/56 and 6/96 -- the noise model's low
#: frequencies, estimated from pieces too short to resolve them, came out 2-7x low.  With
#: each piece's fitted offset put back into the equation group's estimate
#: (``noise_model.DEBIAS``, 9.23) they are 22/118 below 256 samples (36/118 before, the
#: same recordings), 4/78 at 256-511 and 2/44 above: fewer, not gone.
FRAGMENT_SAMPLES = 256


def check_fragmentation(data: Data) -> Check:
    """Many short gap-free segments (:data:`FRAGMENT_SAMPLES`) are reported, never
    refused: the diagnosis runs, but its false-alarm rate there is measured to be higher."""
    lengths = [b - a for a, b in data.segments]
    med = float(np.median(lengths)) if lengths else 0.0
    values = {"segments": len(lengths), "median_samples": med}
    if len(lengths) < 2 or med >= FRAGMENT_SAMPLES:
        return Check("fragmentation", "ok", f"{len(lengths)} gap-free segment(s), median "
                     f"{med:.0f} samples", values)  # fmt: skip
    return Check("fragmentation", "unknown",
                 f"the record is cut into {len(lengths)} gap-free segments of median {med:.0f} "
                 f"samples (< {FRAGMENT_SAMPLES}): the noise model's lowest frequencies come "
                 "from pieces too short to resolve them, and on clean recordings so cut 22 "
                 "in 118 raised a false alarm (docs/mismatch.md 9.23) -- a finding here needs "
                 "a longer uninterrupted stretch to confirm it", values)  # fmt: skip


def check_live(data: Data) -> Check:
    dead = []
    for kind, arr in (("", data.x), ("acc_", data.acc), ("force_", data.force)):
        for a, name in enumerate(AXES):
            if arr.shape[1] and float(np.ptp(arr[a])) == 0.0:
                dead.append(f"{kind}{name} = {arr[a, 0]:.3g}")
    if dead:
        return Check("live channels", "fail",
                     f"constant channel(s) {', '.join(dead)}: a dead sensor, a filler value or "
                     "a noise-free simulation leaves nothing to test against")  # fmt: skip
    return Check("live channels", "ok", "every channel varies")


def check_excitation(data: Data) -> Check:
    """At least one axis carries excitation lines (:meth:`Data.tones`: from the recorded
    reference, else the readout).  The identification of Eq. 10 and every kinematic test
    work at the excitation tones (Eq. 20's multi-sine); a record without a line has
    nothing to identify with -- an unexcited record, or samples out of time order (a
    shuffle spreads a line over the whole band)."""
    found = {AXES[a]: data.tones(a) for a in range(4)}
    excited = {k: v for k, v in found.items() if v}
    if not excited:
        return Check("excitation", "fail",
                     "no excitation line on any axis (no periodogram peak >= 1e4 x its "
                     "surroundings in the references or readouts): the identification needs "
                     "an excited motion (Eq. 20); an unexcited record, or samples out of time "
                     "order?")  # fmt: skip
    return Check("excitation", "ok", "excited axes: " + ", ".join(
        f"{k} ({', '.join(f'{t:.4g}' for t in v)} Hz)" for k, v in excited.items()),
        {k: list(v) for k, v in excited.items()})  # fmt: skip


def check_force_acc(data: Data) -> Check:
    """Slope of N'acc on N'force (f_B-free combinations), the stiffness terms N'(k x)
    removed by regression; first differences suppress slow drifts.  The force channels
    are tried at whole-sample lags -2..2 (a timestamp convention, which the diagnosis
    aligns: :func:`tmopt.mismatch.fit.align_force_timing`), and each axis's force one
    sample later still (an actuation delay of a fraction of a step on one axis puts the
    previous command under an accelerometer sampled at the step's start).  The timing at
    which the force explains most of the acceleration (largest summed ``(slope/se)^2``)
    is judged.  (Not the total R^2: the stiffness terms dominate it, and the rows differ
    slightly between lags across gaps -- a lag at which the force explained nothing was
    once chosen and a consistent recording refused.)"""
    import itertools

    basis = null_basis(data.geometry)
    best = None
    for lag in range(-2, 3):
        pieces = _force_acc_pieces(data, lag)
        if pieces is None:
            continue
        for extra in itertools.product((0, 1), repeat=4):
            vals = _force_acc_slopes(pieces, basis, extra)
            score = sum((v["slope"] / v["se"]) ** 2 for v in vals.values()
                        if math.isfinite(v["slope"]) and v["se"] > 0)  # fmt: skip
            if best is None or score > best[0]:
                best = (score, (lag, extra), vals)
    if best is None:
        return Check("force vs acceleration", "unknown", "too few samples")
    _, (lag, extra), vals = best
    late = [AXES[a] for a in range(4) if extra[a]]
    fails, oks = [], []
    for j, v in enumerate(vals.values()):
        b, se = v["slope"], v["se"]
        if abs(b - 1) > SLOPE_TOLERANCE and abs(b - 1) > SLOPE_Z * se:
            fails.append(f"{b:.3g} +- {se:.2g} in combination {j + 1}")
        elif se < SLOPE_SE_OK and abs(b - 1) <= SLOPE_TOLERANCE:
            oks.append(j)
    vals = {**vals, "force_lag_samples": lag, "one_sample_later_on": late}
    if fails:
        return Check("force vs acceleration", "fail",
                     "the measured accelerations do not follow the commanded forces (slope "
                     f"of acc on force {'; '.join(fails)} in Eq. 10's f_B-free combinations, "
                     f"at the best force timing (lag {lag}"
                     f"{', one more on ' + ', '.join(late) if late else ''}); a closed loop "
                     "gives 1 up to a "
                     "gain error of a few %): unrelated, swapped or rescaled channels?",
                     vals)  # fmt: skip
    if oks:
        return Check("force vs acceleration", "ok", "acc follows force (slope ~1)", vals)
    return Check("force vs acceleration", "unknown",
                 "the forces are too small to verify the relation", vals)  # fmt: skip


def _force_acc_pieces(data: Data, lag: int) -> dict | None:
    """First differences (within segments, each segment's first sample left out: its
    lagged force lies in another) of acc, x and the force at ``lag`` and one sample
    later, per axis."""
    from tmopt.mismatch.fit import _shifted

    d = _shifted(data, lag)
    if d.n < 16:
        return None
    diff = lambda v: _diff_in_segments(d, v, skip=1)  # noqa: E731
    # a difference touching a sample at an accelerometer's rail is no measurement of
    # the force (:func:`saturations`): left out
    rail = np.logical_or.reduce([rail_mask(d.acc[a])[0] for a in range(4)]).astype(float)
    keep = diff(rail) == 0
    keep &= np.concatenate([rail[a + 2 : b] == 0 for a, b in d.segments]) \
        if d.segments else keep  # fmt: skip
    kept = lambda v: diff(v)[keep]  # noqa: E731
    return {"acc": np.array([kept(d.acc[a]) for a in range(4)]),
            "x": np.array([kept(d.x[a]) for a in range(4)]),
            "force": [np.array([kept(d.force[a]) for a in range(4)]),
                      np.array([kept(d.lagged(d.force[a], 1)) for a in range(4)])]}  # fmt: skip


def _force_acc_slopes(pieces: dict, basis: np.ndarray, extra: tuple[int, ...]) -> dict:
    """Per combination: slope of the differenced N'acc on N'force (the force one sample
    later on the axes where ``extra`` is 1), the stiffness terms N'(k x) regressed out,
    with its standard error and R^2."""
    force = np.array([pieces["force"][e][a] for a, e in enumerate(extra)])
    out = {}
    for j in range(2):
        y = basis[:, j] @ pieces["acc"]
        f = basis[:, j] @ force
        xs = basis[:, j, None] * pieces["x"]
        design = np.column_stack([f] + list(xs))
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        res = y - design @ coef
        q, _ = np.linalg.qr(xs.T)
        fp = f - q @ (q.T @ f)
        nn = float(fp @ fp)
        se = math.sqrt(float(np.mean(res**2)) / nn) if nn > 0 else math.inf
        tot = float(np.sum((y - y.mean()) ** 2))
        r2 = 1 - float(res @ res) / tot if tot > 0 else 0.0
        out[f"combination_{j + 1}"] = {"slope": float(coef[0]), "se": se, "r2": r2}
    return out


def _diff_in_segments(data: Data, v: np.ndarray, skip: int = 0) -> np.ndarray:
    return np.concatenate([np.diff(v[a + skip : b]) for a, b in data.segments])


def check_kinematics(data: Data) -> Check:
    """IV slope of the readout's second difference on ``h^2 (a_n + a_{n-1})/2`` at the
    excitation tones of each axis that has them."""
    n = data.kin_index
    h2 = data.dt**2
    vals, fails, oks = {}, [], []
    for a in range(4):
        tones = data.tones(a)
        if not tones:
            continue
        d2x = data.x[a, n + 1] - 2 * data.x[a, n] + data.x[a, n - 1]
        acc = 0.5 * h2 * (data.acc[a, n] + data.acc[a, n - 1])
        z = tone_instrument(acc, data.time[n], tones)
        b, se = _slope(d2x, acc, z)
        vals[AXES[a]] = {"slope": b, "se": se}
        if not math.isfinite(b):
            continue
        if abs(b - 1) > SLOPE_TOLERANCE and abs(b - 1) > SLOPE_Z * se:
            fails.append(f"{AXES[a]}: {b:.3g} +- {se:.2g}")
        elif se < SLOPE_SE_OK and abs(b - 1) <= SLOPE_TOLERANCE:
            oks.append(a)
    if fails:
        return Check("displacement vs acceleration", "fail",
                     "the displacement readouts are not the double integral of the measured "
                     f"accelerations at the excitation tones (slope {'; '.join(fails)}; "
                     "kinematics gives 1): shuffled, swapped or rescaled channels?",
                     vals)  # fmt: skip
    if oks:
        return Check("displacement vs acceleration", "ok",
                     "readouts and accelerations agree at the excitation tones", vals)
    return Check("displacement vs acceleration", "unknown",
                 "no excited axis to verify the kinematics on", vals)  # fmt: skip


def check_controller(data: Data) -> Check:
    """Median windowed R^2 of ``f_n ~ f_{n-1}, f_{n-2}, e_n, e_{n-1}, e_{n-2}`` per axis."""
    w = CONTROLLER_WINDOW
    vals = {}
    for a in range(4):
        ref = data.ref[a] if data.ref is not None and a < 2 else 0.0
        e = ref - data.x[a]
        f = data.force[a]
        r2s = []
        for s0, s1 in data.segments:
            for k in range(s0 + 2, s1 - w + 1, w):
                sl = slice(k, k + w)
                y = f[sl]
                if float(np.ptp(y)) == 0:
                    continue
                design = np.column_stack([np.ones(w), f[k - 1 : k - 1 + w], f[k - 2 : k - 2 + w],
                                          e[sl], e[k - 1 : k - 1 + w], e[k - 2 : k - 2 + w]])
                coef, *_ = np.linalg.lstsq(design, y, rcond=None)
                res = y - design @ coef
                tot = float(np.sum((y - y.mean()) ** 2))
                if tot > 0:
                    r2s.append(1 - float(res @ res) / tot)
                if len(r2s) >= 200:
                    break
        vals[AXES[a]] = float(np.median(r2s)) if r2s else math.nan
    best = max((v for v in vals.values() if math.isfinite(v)), default=math.nan)
    if math.isfinite(best) and best >= LOOP_R2_OK:
        return Check("force vs displacement", "ok",
                     f"the force follows the readouts through a causal controller (median "
                     f"windowed R^2 up to {best:.3f})", vals)  # fmt: skip
    return Check("force vs displacement", "fail",
                 "the commanded forces do not follow the displacement readouts through any "
                 f"causal controller (median R^2 of a 2nd-order model in {w}-sample windows "
                 f"at most {best:.2f} over the four axes; a closed loop gives > {LOOP_R2_OK}):"
                 " not a closed-loop recording, or its samples are shuffled", vals)


def _windows(data: Data, w: int, most: int) -> list[int]:
    """Start indices of up to ``most`` windows of ``w`` samples (two lags before each
    inside its gap-free segment), spread evenly over the record."""
    starts = [k for s0, s1 in data.segments for k in range(s0 + 2, s1 - w + 1, w)]
    if len(starts) > most:
        starts = [starts[i] for i in np.linspace(0, len(starts) - 1, most).round().astype(int)]
    return starts


def _lags(v: np.ndarray, starts: list[int], w: int, lags: tuple[int, ...]) -> np.ndarray:
    """(windows, w, len(lags)): ``v[n - lag]`` over each window."""
    return np.stack([np.column_stack([v[k - j : k - j + w] for j in lags]) for k in starts])


def _rss(design: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Residual sum of squares of y on each window's design (batched least squares),
    columns scaled first (readouts ~1e-9 m beside forces ~1e-9 m s^-2)."""
    scale = np.sqrt(np.sum(design**2, axis=1, keepdims=True))
    q, r = np.linalg.qr(design / np.where(scale > 0, scale, 1.0))
    # rank-deficient windows (a constant reference): drop the null directions' columns
    keep = np.abs(np.diagonal(r, axis1=1, axis2=2)) > 1e-10
    qy = np.einsum("wnp,wn->wp", q, y) * keep
    return np.sum(y**2, axis=1) - np.sum(qy**2, axis=1)


def loop_attribution(data: Data) -> tuple[np.ndarray, np.ndarray]:
    """How the force of axis ``a`` (row) depends on the readout of axis ``b`` (column),
    in windows of :data:`CONTROLLER_WINDOW` samples: the readout's lags ``x_b[n],
    x_b[n-1], x_b[n-2]`` added to ``1, f_a[n-1], f_a[n-2]`` and the reference of ``a``
    (its three lags) -- the terms of a 2nd-order discrete controller acting on
    ``ref_a - x_a``.  Returns two (4, 4) arrays: the fraction of windows in which the
    addition is significant (F-test at :data:`FOLLOW_P`), and the median over windows of
    ``log10(RSS_with / RSS_without)`` (how much of the force's innovation the readout
    explains).  NaN where no window has force variation left to explain."""
    from scipy import stats

    w = CONTROLLER_WINDOW
    starts = _windows(data, w, FOLLOW_WINDOWS)
    frac, logr = np.full((4, 4), math.nan), np.full((4, 4), math.nan)
    if not starts:
        return frac, logr
    for a in range(4):
        f = data.force[a]
        y = np.stack([f[k : k + w] for k in starts])
        base = [np.ones((len(starts), w, 1)), _lags(f, starts, w, (1, 2))]
        if data.ref is not None and a < 2:
            base.append(_lags(data.ref[a], starts, w, (0, 1, 2)))
        base = np.concatenate(base, axis=2)
        rss0 = _rss(base, y)
        live = rss0 > 1e-12 * np.sum(y**2, axis=1)
        if not live.any():
            continue
        dof = w - base.shape[2] - 3
        crit = stats.f.ppf(1 - FOLLOW_P, 3, dof)
        for b in range(4):
            rss1 = _rss(np.concatenate([base, _lags(data.x[b], starts, w, (0, 1, 2))], 2), y)
            rss1, r0 = np.maximum(rss1[live], 1e-300), rss0[live]
            frac[a, b] = float(np.mean((r0 - rss1) / 3 / (rss1 / dof) > crit))
            logr[a, b] = float(np.median(np.log10(rss1 / r0)))
    return frac, logr


#: Another axis's readout explains an axis's force "instead" when it leaves this many
#: decades less of its innovation than the axis's own readout (a closed loop's own
#: readout leaves 1-280 decades less than any other on both simulators' recordings).
SWAP_DECADES = 1.0


def check_axis_loops(data: Data) -> Check:
    """Each axis's force follows its own readout (:func:`loop_attribution`): refuse when
    an axis's force does not depend on its own readout while other axes' forces depend
    on theirs (a shuffled or unrelated readout, or that axis alone not under closed-loop
    control, which this tool's model does not cover), or when another axis's readout
    explains it decisively better (swapped channels)."""
    frac, logr = loop_attribution(data)
    vals = {"follows": {AXES[a]: {AXES[b]: float(frac[a, b]) for b in range(4)}
                        for a in range(4)},
            "log10_residual": {AXES[a]: {AXES[b]: float(logr[a, b]) for b in range(4)}
                               for a in range(4)}}  # fmt: skip
    closed = [a for a in range(4) if frac[a, a] >= FOLLOW_FRACTION]
    if not closed:
        return Check("each axis's own loop", "unknown",
                     "no axis's force verifiably follows its own readout", vals)  # fmt: skip
    broken, bad = [], set()
    for a in range(4):
        if not math.isfinite(frac[a, a]):
            continue
        better = [AXES[b] for b in range(4)
                  if b != a and logr[a, b] < logr[a, a] - SWAP_DECADES]  # fmt: skip
        if better:
            bad.add(a)
            broken.append(f"the force on {AXES[a]} follows the {' and '.join(better)} "
                          f"readout rather than its own (residual 10^{logr[a, a]:.1f} of "
                          f"its innovation with its own, "
                          f"10^{min(logr[a, AXES.index(b)] for b in better):.1f} with "
                          "the other)")  # fmt: skip
        elif frac[a, a] < FOLLOW_FRACTION:
            bad.add(a)
            broken.append(f"the force on {AXES[a]} does not follow its own readout "
                          f"(significant in {frac[a, a]:.0%} of windows)")  # fmt: skip
    fine = [AXES[a] for a in closed if a not in bad]
    if broken:
        return Check("each axis's own loop", "fail",
                     "; ".join(broken)
                     + (f", while the force on {', '.join(fine)} follows its own readout"
                        if fine else "")
                     + f" ({CONTROLLER_WINDOW}-sample windows): "
                     "a shuffled, swapped or unrelated readout channel (or an axis not "
                     "under closed-loop control)?", vals)  # fmt: skip
    return Check("each axis's own loop", "ok",
                 "every axis's force follows its own readout", vals)  # fmt: skip


def precheck(data: Data) -> Verdict:
    """The checks of the module docstring, cheapest first; stops at the first refusal."""
    checks: list[Check] = []
    for fn in (check_length, check_fragmentation, check_live, check_saturation,
               check_excitation, check_force_acc,
               check_kinematics, check_controller, check_axis_loops):
        c = fn(data)
        checks.append(c)
        if c.status == "fail":
            return Verdict(checks, f"cannot diagnose: {c.detail}")
    return Verdict(checks)


#: An explanation is beyond physics when its fitted parameter is past the limit by more
#: than BEYOND_Z standard errors (two-sided ~0.3 %) -- the noise may carry a limit-sized
#: effect past it: the point estimate alone refused a stiffness drift generated at its
#: limit (foreign 170051: kdot = -1e-8 s^-3, fitted -1.01e-8) -- and always when past twice
#: the limit, however uncertain: a degenerate accelerometer scale of -162 +- 10^2 is a
#: unit error's signature, not a calibration (foreign 110102; docs/mismatch.md 9.19).
BEYOND_Z = 3.0

#: The physical range of a test mass's stiffness [s^-2]: LISA Pathfinder-like values are
#: |k| ~ 1e-6..2e-6 (issue 26; Armano et al., PRL 116, 231101 (2016)), the realistic
#: generator draws -2e-6..2e-6 and the paper's Table 2 uses 1e-7 -- 1e-5 is five times
#: the widest.  A model that needs more is absorbing an effect in step with the motion
#: (an actuation gain g at a tone w reads as dk = -g w^2), not measuring a stiffness
#: (docs/mismatch.md 9.20).
STIFFNESS_LIMIT = 1e-5


def beyond_physics(value: float, sigma: float, limit: float, twice: bool = True) -> bool:
    """Is a fitted ``value`` (standard error ``sigma``) past ``limit`` by more than
    :data:`BEYOND_Z` standard errors, or (``twice``) past twice the limit however
    uncertain?  ``twice=False`` for a nominal parameter -- an unexcited axis's stiffness
    is legitimately uncertain (k1yy = 3e-5 +- 1.4e-5 on kernel 180032), and only the
    data's exclusion of the range says anything.  NaN or infinite inputs are not judged
    (False)."""
    sigma = sigma if isinstance(sigma, (int, float)) and math.isfinite(sigma) else 0.0
    slack = min(BEYOND_Z * sigma, limit) if twice else BEYOND_Z * sigma
    return isinstance(value, (int, float)) and math.isfinite(value) and \
        abs(value) - slack > limit  # fmt: skip


def implausible_effects(effects: list[dict]) -> str | None:
    """A reason to refuse when a selected explanation is beyond physics: a fitted main
    parameter larger than the effect's range (``Effect.limit``, the generator's and the
    catalogue's physical maximum) by more than :data:`BEYOND_Z` of its standard error
    (``e["uncertainties"]``, when given) or by more than the limit itself -- a unit error
    or a swapped channel, not that effect."""
    from tmopt.mismatch.effects import EFFECTS

    for e in effects:
        model = EFFECTS.get(e["name"])
        if model is None:
            continue
        main = "d_alpha" if model.parameter == "d_angle" else model.parameter
        bounds = [(main, model.parameter, model.limit, model.unit)]
        bounds += [(k, k, lim, "") for prefix, lim in model.side_limits.items()
                   for k in e["parameters"] if k.startswith(prefix)]  # fmt: skip
        for key, shown, limit, unit in bounds:
            value = e["parameters"].get(key)
            if beyond_physics(value, e.get("uncertainties", {}).get(key, 0.0), limit):
                return (f"cannot diagnose: the best explanation needs {e['name']} "
                        f"[{e['channel']}] with {shown} = {value:.3g} {unit}".rstrip()
                        + f", beyond its physical range (|{shown}| <= {limit:g}): "
                        "a unit error, a swapped or a rescaled channel?")
    return None
