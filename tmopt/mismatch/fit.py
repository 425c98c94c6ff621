"""Nominal model of a recording (Eqs. 1-2, 9-15), its residuals, and the linear fit engine.

Per test-mass axis ``a`` in ``x1, x2, y1, y2`` (TM1 in frame a, TM2 in frame b), Eqs. 1-2
with the rotation terms dropped (Sec. 2.2) give, sample by sample,

    acc_a - f_a = k_a x_a + f_D,a - (P f_B)_a + noise            (per unit mass)

with ``f`` the commanded force, ``x`` the displacement readout, ``P`` (4x2) the projection
of the spacecraft acceleration ``f_B`` (in-plane, frame s) onto the four axes through
``W_sa`` and ``W_sb`` (Eqs. 5-7).  ``f_B`` is unknown at every sample; the left null space
of ``P`` is 2-D (:func:`null_basis`).  Its first vector is Eq. 11's ``K`` (normalised), so
the first combination *is* the paper's regression ``y = K.(r'' - f_e) = psi' theta``
(Eqs. 10-15); the second is the other f_B-free combination.  Fitting both (the
**equation** group) is the same as estimating ``f_B`` as a per-sample nuisance, and lets a
residual be traced to an axis through its 2-D direction.

The **kinematic** group checks the readouts against the accelerometer (not used by
Eqs. 9-16).  For ``r'' = k r + u`` with the force ``u`` held over each step (ZOH) the
samples obey exactly (``C = cosh(sqrt(k) h)``, ``g = (C - 1)/k``; both real for k < 0):

* accelerometer sampling ``held`` (``a_n = k r(t_n) + u_n``, this package's simulator):
  ``x_{n+1} - (1 + C) x_n + C x_{n-1} = g (a_n + a_{n-1})``;
* accelerometer sampling ``mean`` (``a_n`` = mean acceleration over ``[t_n, t_{n+1})``,
  an integrating sensor): ``x_{n+1} - 2 x_n + x_{n-1} = beta (a_n + a_{n-1})`` with
  ``beta = h (C - 1)/(sqrt(k) sinh(sqrt(k) h))``;
* accelerometer sampling ``end`` (``a_n = k r(t_{n+1}) + u_n``, read after the step):
  ``C x_{n+1} - (1 + C) x_n + x_{n-1} = g (a_n + a_{n-1})``

(:func:`kinematic_coefficients`; derivation in docs/mismatch.md 9.4, 9.25).  A simulator
that takes Euler steps and records the acceleration at the sample obeys the ``held`` form
with a *half-step* term, ``beta g (a_n - a_{n-1})`` beside ``g (a_n + a_{n-1})``: ``beta``
= +1 for one symplectic Euler (or Verlet) step per sample (``x_{n+1} - 2 x_n + x_{n-1} =
h^2 a_n`` exactly, at any k), -1 for one explicit Euler step (``h^2 a_{n-1}``), ``+-1/N``
for N sub-steps (``Data.halfstep``, chosen from the data: :func:`_halfstep`; 9.26).  A
readout that reports the step's mean position adds a *curvature* term ``lambda h^2`` times
the accelerations' second difference beside the explicit one (``lambda`` = 1/6;
``Data.curvature``, :func:`choose_curvature`; 9.27).  The ZOH relations reduce to
``h^2/2`` at k = 0; ``held`` and ``end`` differ from the k = 0 form by ``~k h^3 v/2``, which
at LPF-like |k| ~ 1e-6..2e-6 s^-2 reaches ~1e-13 m per sample at 2 Hz.  k is the
equation group's estimate; the convention is read from the recording's ``acc_sampling``
attribute or chosen from the data (:func:`choose_acc_convention`).  Kinematic candidates
are estimated with instrumental variables (the excitation tones), because the loop feeds
the readout noise back into the measured acceleration.

**Gaps**: a recording with NaN runs or dropped rows is analysed on all its gap-free
segments of at least :data:`MIN_SEGMENT` samples (``Data.segments``); per-sample relations
use every valid sample, differences and lags never cross a gap, and the noise models treat
each segment separately (:class:`tmopt.mismatch.noise_model.Layout`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import signal

from tmopt.mismatch.noise_model import Layout, taper
from tmopt.mismatch.true_position import readout_noise
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import AXES

__all__ = [
    "AXES",
    "Data",
    "Column",
    "FitResult",
    "data_from_recording",
    "data_from_result",
    "fb_projection",
    "null_basis",
    "equation_target",
    "nominal_equation_columns",
    "kinematic_target",
    "switch_series",
    "nominal_kinematic_columns",
    "solve",
    "solve_iv",
    "tone_instrument",
    "tone_part",
    "excitation_tones",
    "output_error",
    "kinematic_coefficients",
    "align_kinematics",
    "drop_samples",
    "choose_acc_convention",
    "MIN_SEGMENT",
]


#: Shortest gap-free segment used (shorter pieces between gaps are left out and counted):
#: MIN_SEGMENT samples, and SEGMENT_FRACTION of the longest segment.  A short piece has
#: its own lowest frequency far above the record's: the red noise below it (the readout's
#: 1/f excess; the acceleration's 1/f^2) enters its few bins as a large offset and trend
#: that a stationary noise model of the whole record cannot describe -- one 69-sample
#: piece of a 7024-sample record made clean recordings "show" cross-talk at GLR 700.
MIN_SEGMENT = 64
SEGMENT_FRACTION = 0.125


@dataclass
class Data:
    """One recording as arrays (axis order :data:`AXES`): ``x``, ``acc``, ``force`` (4, N)
    over the valid samples of its gap-free ``segments`` ([(start, stop)] into these
    arrays; one segment without gaps).  ``time`` keeps the recording's clock, so it jumps
    across gaps.  ``usage`` says how much of the recording this is."""

    time: np.ndarray
    fs: float
    x: np.ndarray
    acc: np.ndarray
    force: np.ndarray
    geometry: Geometry
    ref: np.ndarray | None = None
    omega: np.ndarray | None = None
    omega_dot: np.ndarray | None = None
    source: str = "<memory>"
    notes: list[str] = field(default_factory=list)
    segments: list[tuple[int, int]] | None = None
    usage: dict = field(default_factory=dict)
    acc_convention: str = "held"
    # the kinematic relation's half-step coefficient (Euler steps; 0: the ZOH relations)
    halfstep: float = 0.0
    # its curvature coefficient (an integrating readout, a smooth simulator; 0: none)
    curvature: float = 0.0
    stiffness: np.ndarray | None = None  # k per axis for the exact kinematics (None: 0)
    # the stiffness regressors on the true position: the readout noise taken out
    # (:mod:`tmopt.mismatch.true_position`); False: on the readout as recorded
    true_position: bool = True

    def __post_init__(self) -> None:
        if self.segments is None:
            self.segments = [(0, int(self.time.size))]

    @property
    def n(self) -> int:
        return int(self.time.size)

    @property
    def dt(self) -> float:
        return 1.0 / self.fs

    @property
    def centred_time(self) -> np.ndarray:
        return self.time - 0.5 * (self.time[0] + self.time[-1])

    @property
    def x_eq(self) -> np.ndarray:
        """Positions as the accelerometer sees them (the stiffness term of Eq. 10): the
        true position ``r(t_n)`` for the ``held`` convention, the interval mean
        ``(r_n + r_{n+1})/2`` for ``mean`` (exact to ``k a h^2/12`` ~ 1e-16 m s^-2), the
        step's end ``r_{n+1}`` for ``end`` (the last sample of a segment keeps ``r_n``).
        ``r`` is the readout less its estimated noise
        (:func:`tmopt.mismatch.true_position.readout_noise`; the readout itself when
        ``true_position`` is False): ``k n_r`` is correlated with the force the loop makes
        from ``n_r`` (docs/mismatch.md 9.19)."""
        key = (self.acc_convention, self.halfstep, self.curvature, self.true_position,
               None if self.stiffness is None else np.asarray(self.stiffness, float).tobytes())
        cache = self.__dict__.setdefault("_x_eq", {})
        if key not in cache:
            r = self.x
            if self.true_position:
                r = r - readout_noise(self.x, kinematic_target(self), self.segments, self.fs)
            if self.acc_convention in ("mean", "end"):
                w = 0.5 if self.acc_convention == "mean" else 1.0  # the weight of r_{n+1}
                out = r.copy()
                for a, b in self.segments:
                    out[:, a : b - 1] = (1 - w) * r[:, a : b - 1] + w * r[:, a + 1 : b]
                r = out
            cache.clear()
            cache[key] = r
        return cache[key]

    @property
    def layout(self) -> Layout:
        return Layout(tuple((int(a), int(b)) for a, b in self.segments), self.n)

    @property
    def kin_index(self) -> np.ndarray:
        """Sample index n of each kinematic row (n - 1, n, n + 1 in one segment)."""
        return np.concatenate([np.arange(a + 1, b - 1) for a, b in self.segments])

    @property
    def kin_layout(self) -> Layout:
        bounds, at = [], 0
        for a, b in self.segments:
            bounds.append((at, at + b - a - 2))
            at += b - a - 2
        return Layout(tuple(bounds), at)

    @property
    def longest(self) -> slice:
        a, b = max(self.segments, key=lambda s: s[1] - s[0])
        return slice(a, b)

    def lagged(self, series: np.ndarray, j: int) -> np.ndarray:
        """``series[n - j]`` within each segment, 0 where n - j is in another segment."""
        out = np.zeros_like(series)
        for a, b in self.segments:
            if b - a > j:
                out[..., a + j : b] = series[..., a : b - j]
        return out

    def tones(self, axis: int) -> list[float]:
        """Excitation lines [Hz] of an axis: from the reference when recorded, else from
        the displacement readout itself (y axes: none unless they move); found on the
        longest gap-free segment."""
        cache = self.__dict__.setdefault("_tones", {})
        if axis not in cache:
            src = self.ref[axis] if self.ref is not None and axis < 2 else self.x[axis]
            cache[axis] = excitation_tones(src[self.longest], self.fs)
        return cache[axis]


def excitation_tones(x: np.ndarray, fs: float, max_tones: int = 6) -> list[float]:
    """Frequencies [Hz] of the strongest lines of a series: Hann-windowed periodogram peaks
    at least 1e4 x the median of their surroundings (bins k/2 .. max(2k, k + 32), the peak's
    own +-4 bins left out) -- a deterministic excitation, not noise, even on a red readout
    spectrum (a 1/f^2 readout excess is 1e3-1e4 x its white floor at the lowest bins,
    which a record-wide median would call lines)."""
    m = x.size
    if m < 16:
        return []
    per = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(m))) ** 2
    f = np.fft.rfftfreq(m, 1 / fs)
    floor = 1e-300 + 1e-30 * float(per.max())
    peaks, _ = signal.find_peaks(per, height=1e3 * np.median(per[1:]) + floor)
    keep = []
    for k in peaks:
        lo, hi = max(1, k // 2), min(per.size, max(2 * k, k + 32))
        around = np.concatenate([per[lo : max(lo, k - 4)], per[min(hi, k + 5) : hi]])
        local = float(np.median(around)) if around.size >= 8 else float(np.median(per[1:]))
        if per[k] >= 1e4 * local + floor:
            keep.append(k)
    keep = sorted(keep, key=lambda k: -per[k])[:max_tones]
    return sorted(_refine_tone(x, fs, float(f[k])) for k in keep if k > 0)


def _refine_tone(x: np.ndarray, fs: float, f0: float) -> float:
    """Frequency within +-1 bin of ``f0`` maximising the least-squares sinusoid power (a
    tone between two bins would otherwise give a mismatched instrument)."""
    m = x.size
    t = np.arange(m) / fs
    grid = f0 + np.linspace(-1.0, 1.0, 81) * fs / m
    grid = grid[grid > 0]
    xc = x - x.mean()
    arg = 2 * math.pi * grid[:, None] * t[None]
    s, c = np.sin(arg), np.cos(arg)
    # least-squares sinusoid power via the 2x2 normal equations, all frequencies at once
    ss, cc, sc = np.sum(s * s, 1), np.sum(c * c, 1), np.sum(s * c, 1)
    bs, bc = s @ xc, c @ xc
    det = ss * cc - sc**2
    power = (cc * bs**2 - 2 * sc * bs * bc + ss * bc**2) / np.maximum(det, 1e-300)
    return float(grid[int(np.argmax(power))])


def _shortest_kept(longest: int) -> int:
    """The shortest gap-free piece kept beside a longest one of ``longest`` samples
    (:data:`MIN_SEGMENT`, :data:`SEGMENT_FRACTION`)."""
    return max(MIN_SEGMENT, int(SEGMENT_FRACTION * longest))


def _gathered(pieces: list[tuple[int, int]]) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """The sample indices of ``pieces`` ([(start, stop)]) in order, and their bounds in the
    gathered array."""
    idx = np.concatenate([np.arange(a, b) for a, b in pieces]) if pieces else \
        np.zeros(0, dtype=np.int64)  # fmt: skip
    bounds, at = [], 0
    for a, b in pieces:
        bounds.append((at, at + b - a))
        at += b - a
    return idx, bounds


def _valid_segments(rec) -> tuple[list[slice], dict, list[str]]:
    """Gap-free segments of at least MIN_SEGMENT samples, the usage summary and notes."""
    n = rec.n_samples
    segs = rec.segments(1)
    longest = max((s.stop - s.start for s in segs), default=0)
    shortest = _shortest_kept(longest)
    kept = [s for s in segs if s.stop - s.start >= shortest]
    valid = int(sum(s.stop - s.start for s in segs))
    used = int(sum(s.stop - s.start for s in kept))
    usage = {"samples_recorded": n, "samples_valid": valid, "samples_used": used,
             "segments_used": len(kept), "segments_dropped": len(segs) - len(kept),
             "gaps": len(rec.gaps), "fraction_used": used / n if n else 0.0}  # fmt: skip
    notes = []
    if rec.gaps:
        notes.append(f"{n - valid} masked samples in {len(rec.gaps)} gap(s): analysed "
                     f"{len(kept)} gap-free segment(s), {used} of {n} samples "
                     f"({100 * used / n:.1f} %)")  # fmt: skip
    if len(kept) < len(segs):
        notes.append(f"{len(segs) - len(kept)} segment(s) shorter than {shortest} samples "
                     f"between gaps were left out ({valid - used} samples)")  # fmt: skip
    return kept, usage, notes


#: The recording attribute naming the accelerometer's sampling convention.
ACC_ATTRIBUTE = "acc_sampling"
ACC_CONVENTIONS = ("held", "mean", "end")
#: ``acc_sampling`` values of an Euler integrator's recording (the acceleration at the
#: sample, the one its step used; in Eq. 10 that is ``held``) -> the half-step coefficient
#: of its kinematic relation (:func:`kinematic_coefficients`; docs/mismatch.md 9.26).
HALFSTEP_ATTRIBUTES = {"symplectic": 1.0, "explicit": -1.0}
#: Estimate a half-step term from the data (:func:`_halfstep`); False: stop 49's tool.
HALFSTEP = True
#: Read an integrating readout (9.27): the half-step estimate snapped to +-1 within
#: HALFSTEP_SLACK too, and -1 kept where Eq. 10 places the stiffness term away from
#: ``held``; False: stop 50's rule (snapped within 3 standard errors, kept with ``held``).
INTEGRATING_READOUT = True


def data_from_recording(rec) -> Data:
    """A validated :class:`~tmopt.physics.recording.Recording` -> :class:`Data`.

    Gaps (NaN samples) are not filled: every gap-free segment of at least
    :data:`MIN_SEGMENT` samples is kept (``Data.segments``) and a note says how much of the
    record is used.  A recording without such a segment gives a :class:`Data` with no
    samples (the plausibility checks then refuse it).  An ``acc_sampling`` attribute
    (one of :data:`ACC_CONVENTIONS`) fixes the accelerometer convention of the kinematic
    check; another value is named in a note and the convention chosen from the data.
    """
    segs, usage, notes = _valid_segments(rec)
    idx, bounds = _gathered([(s.start, s.stop) for s in segs])

    def take(name: str) -> np.ndarray:
        return np.asarray(rec[name], float)[idx]

    def stack(fmt: str) -> np.ndarray:
        return np.array([take(fmt.format(a)) for a in AXES]).reshape(4, idx.size)

    rot = "sc_omega_x" in rec
    conv = str(rec.attrs.get(ACC_ATTRIBUTE, "")).strip().lower()
    data = Data(
        time=take("time"),
        fs=float(rec.attrs["sample_rate"]),
        x=stack("{}"),
        acc=stack("acc_{}"),
        force=stack("force_{}"),
        geometry=Geometry(float(rec.attrs["phi1"]), float(rec.attrs["phi2"])),
        ref=np.array([take("ref_x1"), take("ref_x2")]) if "ref_x1" in rec else None,
        omega=np.array([take(f"sc_omega_{c}") for c in "xyz"]) if rot else None,
        omega_dot=np.array([take(f"sc_omega_dot_{c}") for c in "xyz"]) if rot else None,
        source=str(getattr(rec, "source", "<memory>")),
        notes=notes,
        segments=bounds,
        usage=usage,
    )  # fmt: skip
    if conv in HALFSTEP_ATTRIBUTES:
        data.acc_convention, data.halfstep = "held", HALFSTEP_ATTRIBUTES[conv]
        data.usage["acc_convention_from"] = "attribute"
    elif conv in ACC_CONVENTIONS:
        data.acc_convention = conv
        data.usage["acc_convention_from"] = "attribute"
    elif conv:
        data.notes.append(f"attribute {ACC_ATTRIBUTE}={conv!r} is not one of "
                          f"{ACC_CONVENTIONS + tuple(HALFSTEP_ATTRIBUTES)}: the convention is "
                          "chosen from the data")
    return data


#: A whole-sample shift of the force channels is taken only if it divides the nominal
#: residual by at least this much (a sub-sample actuation delay makes any shift worse).
ALIGN_GAIN = 2.0


def _shifted(data: Data, lag: int, what: str = "force") -> Data:
    """``data`` with ``<what>[n + lag]`` paired with the other channels' sample n, within
    each segment (ends cut).  ``what`` = ``force`` (force vs acceleration, Eq. 10) or
    ``x`` (readouts vs accelerometer, the kinematic check)."""
    if lag == 0:
        return data
    keep, move, bounds, at = [], [], [], 0
    for a, b in data.segments:
        k = np.arange(a, b - lag) if lag > 0 else np.arange(a - lag, b)
        if k.size < 3:
            continue
        keep.append(k)
        move.append(k + lag)
        bounds.append((at, at + k.size))
        at += k.size
    keep = np.concatenate(keep) if keep else np.zeros(0, np.int64)
    move = np.concatenate(move) if move else np.zeros(0, np.int64)

    def cut(arr):
        return None if arr is None else arr[..., keep]

    shifted = {"force": data.force[:, move] if what == "force" else data.force[:, keep],
               "x": data.x[:, move] if what == "x" else data.x[:, keep]}  # fmt: skip
    out = replace(data, time=data.time[keep], x=shifted["x"], acc=data.acc[:, keep],
                  force=shifted["force"], ref=cut(data.ref), omega=cut(data.omega),
                  omega_dot=cut(data.omega_dot), notes=list(data.notes), segments=bounds,
                  usage=dict(data.usage))  # fmt: skip
    out.__dict__.pop("_tones", None)
    out.__dict__.pop("_x_eq", None)
    return out


def drop_samples(data: Data, drop: np.ndarray, why: str) -> Data:
    """``data`` without the samples where ``drop`` (N,) is True, each left out as a gap:
    the segments split there, and pieces shorter than the rule of :func:`_valid_segments`
    (:data:`MIN_SEGMENT`, :data:`SEGMENT_FRACTION` of the longest) are left out too.
    ``usage`` counts what was left out and a note says ``why`` (the caller's words)."""
    drop = np.asarray(drop, bool)
    if drop.shape != (data.n,):
        raise ValueError(f"drop must have shape ({data.n},); got {drop.shape}")
    runs = []
    for a, b in data.segments:
        keep = np.flatnonzero(~drop[a:b]) + a
        if keep.size:  # split where a dropped sample sits between two kept ones
            cut = np.flatnonzero(np.diff(keep) > 1) + 1
            runs += [(int(r[0]), int(r[-1]) + 1) for r in np.split(keep, cut)]
    shortest = _shortest_kept(max((b - a for a, b in runs), default=0))
    kept = [(a, b) for a, b in runs if b - a >= shortest]
    idx, bounds = _gathered(kept)

    def take(arr):
        return None if arr is None else arr[..., idx]

    usage = dict(data.usage)
    recorded = int(usage.get("samples_recorded", data.n))
    usage.update({"samples_used": int(idx.size), "segments_used": len(kept),
                  "segments_dropped": int(usage.get("segments_dropped", 0))
                  + len(runs) - len(kept),
                  "samples_left_out": int(usage.get("samples_left_out", 0))
                  + data.n - int(idx.size),
                  "fraction_used": idx.size / recorded if recorded else 0.0})  # fmt: skip
    note = (f"{int(drop.sum())} samples left out as gaps ({why}); {len(runs) - len(kept)} "
            f"piece(s) between them shorter than {shortest} samples left out too: analysed "
            f"{len(kept)} segment(s), {idx.size} of {recorded} samples")  # fmt: skip
    out = replace(data, time=data.time[idx], x=data.x[:, idx], acc=data.acc[:, idx],
                  force=data.force[:, idx], ref=take(data.ref), omega=take(data.omega),
                  omega_dot=take(data.omega_dot), notes=list(data.notes) + [note],
                  segments=bounds, usage=usage)  # fmt: skip
    out.__dict__.pop("_tones", None)
    out.__dict__.pop("_x_eq", None)
    return out


def _nominal_rms(data: Data, basis: np.ndarray) -> float:
    fit = solve(equation_target(data, basis), nominal_equation_columns(data, basis),
                lambda v: v)
    return float(np.sqrt(np.mean(fit.residual**2)))


def force_lag(data: Data, max_lag: int = 2) -> tuple[int, dict[int, float]]:
    """The whole-sample lag of the force channels (``force[n + lag]`` acts on sample n)
    that best fits Eq. 10, 0 unless it divides the nominal residual by ``ALIGN_GAIN``;
    with the nominal residual rms per lag tried.  The one criterion of
    :func:`align_force_timing` (the benchmark's SNR scaler uses it too)."""
    basis = null_basis(data.geometry)
    rms = {lag: _nominal_rms(_shifted(data, lag), basis) for lag in range(-max_lag, max_lag + 1)
           if data.n - abs(lag) > 16}
    best = min(rms, key=rms.get)
    if best == 0 or rms[0] < ALIGN_GAIN * rms[best]:
        return 0, rms
    return best, rms


def align_force_timing(data: Data, max_lag: int = 2) -> Data:
    """Pair each acceleration sample with the force sample that acts on it.

    Simulators differ in how they stamp the commanded force: the force computed at step n
    and applied from t_n on (this package's convention), or the force that produced the
    acceleration measured at t_n (applied from t_(n-1)). Read with the wrong pairing, Eq.
    10 fails by the force's step-to-step change — far above the noise — and every later
    test goes astray. So, as part of the nominal model, the integer lag in
    ``[-max_lag, max_lag]`` that best fits Eq. 10 is chosen (taken only if it divides the
    residual by ``ALIGN_GAIN``), the channels are aligned and a note says so: physically
    the same data would be an actuation delay of that many samples.
    """
    best, rms = force_lag(data, max_lag)
    if best == 0:
        return data
    out = _shifted(data, best)
    side = "late" if best > 0 else "early"
    out.notes.append(
        f"the force channels are stamped {abs(best)} sample(s) {side} relative to the "
        f"accelerations (nominal residual {rms[0]:.3g} -> {rms[best]:.3g} m s^-2 when "
        f"aligned); they were aligned before the diagnosis. This is a timestamp convention "
        f"of the recording, or physically an actuation delay of {abs(best) / data.fs:g} s")
    return out


def data_from_result(result, i: int = 0) -> Data:
    """Design ``i`` of a :class:`~tmopt.physics.simulator.SimulationResult` (tests, studies)."""
    d = result.design(i)
    cfg = result.config
    return Data(
        time=np.asarray(d["time"], float),
        fs=float(cfg.sample_rate),
        x=np.array([d[a] for a in AXES]),
        acc=np.array([d[f"acc_{a}"] for a in AXES]),
        force=np.array([d[f"force_{a}"] for a in AXES]),
        geometry=cfg.geometry,
        ref=np.array([d["ref_x1"], d["ref_x2"]]),
        source="<simulation>",
    )


def kinematic_coefficients(k: np.ndarray, h: float, convention: str, halfstep: float = 0.0):
    """Per-axis exact ZOH kinematic coefficients for stiffness ``k`` (4,).

    Returns ``(c_prev, c_mid, g)`` with the relation ``x_{n+1} - c_mid x_n + c_prev x_{n-1}
    = g (a_n + a_{n-1})``: ``held`` -> ``(C, 1 + C, (C - 1)/k)``, ``mean`` ->
    ``(1, 2, h (C - 1)/(sqrt(k) sinh(sqrt(k) h)))``, ``end`` (``a_n = k r(t_{n+1}) + u_n``)
    -> ``(1/C, 1 + 1/C, (C - 1)/(k C))``, ``C = cosh(sqrt(k) h)``.  All three follow from
    the ZOH step's ``x_{n+1} - 2 C x_n + x_{n-1} = ((C - 1)/k)(u_n + u_{n-1})`` with ``u``
    replaced by what the accelerometer read (docs/mismatch.md 9.4, 9.25); power series
    in ``z = k h^2`` (|z| < 1e-4 here, so 6 terms are exact to double precision and k < 0
    needs no complex square root).

    ``halfstep`` (``beta``; the relation's acceleration term is then ``g
    ((a_n + a_{n-1}) + beta (a_n - a_{n-1}))``, :func:`acc_sum`): Euler steps with the
    acceleration at the sample.  One step per sample (``beta`` = +-1) is exact with ``(1,
    2, h^2/2)`` at any k (the recorded ``a_n`` holds ``k r_n``); N sub-steps give ``beta =
    +-1/N`` and k terms between the two forms -- taken as the ``|beta|``-weighted mean of
    the Euler and ``held`` coefficients, which leaves 1e-8 of the second difference on
    noise-free sub-stepped recordings at |k| = 2e-6 (either form alone 1e-6;
    docs/mismatch.md 9.26).
    """
    if halfstep:
        w = min(abs(float(halfstep)), 1.0)
        c_prev, c_mid, g = kinematic_coefficients(k, h, "held")
        return (1 - w) * c_prev + w, (1 - w) * c_mid + 2 * w, (1 - w) * g + w * h * h / 2
    z = np.asarray(k, float) * h * h
    # cosh(sqrt z) = sum z^j/(2j)!, (C - 1)/z = sum z^j/(2j+2)!,
    # sinh(sqrt z)/sqrt z = sum z^j/(2j+1)!
    fact = [math.factorial(i) for i in range(14)]
    cosh = sum(z**j / fact[2 * j] for j in range(6))
    cm1_z = sum(z**j / fact[2 * j + 2] for j in range(6))
    sinh_z = sum(z**j / fact[2 * j + 1] for j in range(6))
    if convention == "held":
        return cosh, 1.0 + cosh, h * h * cm1_z
    if convention == "mean":
        one = np.ones_like(z)
        return one, 2.0 * one, h * h * cm1_z / sinh_z
    if convention == "end":
        return 1.0 / cosh, 1.0 + 1.0 / cosh, h * h * cm1_z / cosh
    raise ValueError(f"convention must be one of {ACC_CONVENTIONS}; got {convention!r}")


def fb_projection(geometry: Geometry) -> np.ndarray:
    """P (4, 2): in-plane f_B^s seen along x1, x2, y1, y2 (rows of W_sa, W_sb; Eqs. 6-7)."""
    wa, wb = geometry.w_sa[:2, :2], geometry.w_sb[:2, :2]
    return np.array([wa[0], wb[0], wa[1], wb[1]])


def fb_projection_dphi2(geometry: Geometry) -> np.ndarray:
    """dP/dphi2 (4, 2): only TM2's rows depend on phi2 (Eq. 7 differentiated)."""
    c, s = math.cos(geometry.phi2), math.sin(geometry.phi2)
    out = np.zeros((4, 2))
    out[1] = [-s, c]
    out[3] = [-c, -s]
    return out


def null_basis(geometry: Geometry) -> np.ndarray:
    """N (4, 2), orthonormal, ``N' P = 0``; column 0 is Eq. 11's K / |K|.

    Column 1 completes the null space of P' (the f_B-free combinations); its sign makes
    its largest-magnitude entry positive, so the basis is deterministic.
    """
    p = fb_projection(geometry)
    k = geometry.coefficients()
    k = k / np.linalg.norm(k)
    _, _, vt = np.linalg.svd(np.column_stack([p, k]).T)
    n2 = vt[-1]
    n2 = n2 * np.sign(n2[np.argmax(np.abs(n2))])
    return np.column_stack([k, n2])


@dataclass
class Column:
    """One regressor: ``values`` has the shape of its group's target, ``name`` its parameter.

    ``instrument`` (same shape), when given, is the instrumental variable used for this
    column in :func:`solve_iv` -- a version of the regressor free of the noise that the
    control loop feeds back into it.
    """

    name: str
    values: np.ndarray
    instrument: np.ndarray | None = None
    tones: tuple[float, ...] = ()  # instrument's lines [Hz] (kinematic columns)
    row: int | None = None  # the one channel the column acts on, when it is one


def axis_column(basis: np.ndarray, axis: int, series: np.ndarray) -> np.ndarray:
    """Per-axis regressor ``series`` on axis ``axis`` seen in the f_B-free combinations."""
    return np.outer(basis[axis], series)


def equation_target(data: Data, basis: np.ndarray) -> np.ndarray:
    """Eq. 10's output for both combinations: ``N' (acc - f)`` (2, N)."""
    return basis.T @ (data.acc - data.force)


def nominal_equation_columns(data: Data, basis: np.ndarray,
                             shift: np.ndarray | None = None) -> list[Column]:  # fmt: skip
    """Eqs. 12-15: stiffness ``k_a x_a`` per axis and the two bias combinations ``N' f_D``
    -- one pair per gap-free segment (``R1``, ``R2`` on the first, ``R1@s``, ``R2@s`` on
    segment s): red noise wanders across a gap, and a segment's offset from the others
    would otherwise sit in its lowest bins, which the noise model cannot know about.
    ``shift`` (4, N): added to the positions the stiffness acts on (the true position
    under a readout cross-talk, ``diagnose._position_shift``)."""
    names = ("k1xx", "k2xx", "k1yy", "k2yy")
    x = data.x_eq if shift is None else data.x_eq + shift
    cols = [Column(nm, axis_column(basis, a, x[a])) for a, nm in enumerate(names)]
    for s, (a, b) in enumerate(data.segments):
        for j in range(basis.shape[1]):
            v = np.zeros((basis.shape[1], data.n))
            v[j, a:b] = 1.0
            cols.append(Column(f"R{j + 1}" + (f"@{s + 1}" if s else ""), v))
    return cols


def _kin_coefficients(data: Data):
    k = np.zeros(4) if data.stiffness is None else np.asarray(data.stiffness, float)
    return kinematic_coefficients(k, data.dt, data.acc_convention, data.halfstep)


def acc_sum(data: Data) -> np.ndarray:
    """The accelerations (4, rows) that ``g`` multiplies in the relation: ``a_n + a_{n-1}``,
    with a half-step term ``beta (a_n - a_{n-1})`` beside it (``Data.halfstep``: Euler
    steps) and a curvature term ``2 lambda`` times :func:`acc_curvature`
    (``Data.curvature``: an integrating readout); one row per ``Data.kin_index`` sample."""
    n = data.kin_index
    if data.halfstep:
        beta = float(data.halfstep)
        out = (1 + beta) * data.acc[:, n] + (1 - beta) * data.acc[:, n - 1]
    else:
        out = data.acc[:, n] + data.acc[:, n - 1]
    if data.curvature:
        out = out + 2.0 * float(data.curvature) * acc_curvature(data)
    return out


def acc_curvature(data: Data) -> np.ndarray:
    """The accelerations' second difference (4, rows) where the relation's centre sits:
    ``c_n = a_{n+1} - 2 a_n + a_{n-1}`` and ``c_{n-1}``, weighted ``(1 + beta)/2`` and
    ``(1 - beta)/2`` by the half-step term (``beta`` = +1 puts the centre at sample n, -1
    at n - 1, 0 between).  Over a step whose readout is the mean position of the step
    that ends at t_n the relation is ``x_{n+1} - 2 x_n + x_{n-1} = h^2 (a_{n-2} + 4
    a_{n-1} + a_n)/6`` at k = 0: ``beta = -1`` and ``lambda = 1/6`` with ``c_{n-1}``; a
    trapezoid of the samples ``(x_n + x_{n+1})/2`` gives ``beta = +1``, ``lambda = 1/4``
    with ``c_n``; a smooth acceleration sampled at the instants (Numerov) ``+1``, ``1/12``
    (docs/mismatch.md 9.27).  Placed elsewhere the term is right at the tones to
    ``(w h)^3`` but not across a start-up transient.  At a segment's first row, whose
    ``a_{n-2}`` lies across the gap, ``c_n`` stands in for ``c_{n-1}``."""
    n = data.kin_index
    a = data.acc
    c_n = a[:, n + 1] - 2.0 * a[:, n] + a[:, n - 1]
    w = 0.5 * (1.0 + float(data.halfstep))
    if w >= 1.0:
        return c_n
    c_prev = a[:, n] - 2.0 * a[:, n - 1] + data.lagged(a, 2)[:, n]
    across = data.lagged(np.ones(data.n), 2)[n] == 0  # n - 2 in another segment
    c_prev[:, across] = c_n[:, across]
    return w * c_n + (1.0 - w) * c_prev


def kinematic_target(data: Data) -> np.ndarray:
    """The exact kinematic residual (4, rows), one row per ``Data.kin_index`` sample:
    ``x_{n+1} - c_mid x_n + c_prev x_{n-1} - g acc_sum`` (:func:`kinematic_coefficients`
    and :func:`acc_sum` with ``data.stiffness`` and ``data.acc_convention``)."""
    n = data.kin_index
    c_prev, c_mid, g = (np.asarray(v, float)[:, None] for v in _kin_coefficients(data))
    return (data.x[:, n + 1] - c_mid * data.x[:, n] + c_prev * data.x[:, n - 1]
            - g * acc_sum(data))  # fmt: skip


def kinematic_series(data: Data, axis: int) -> np.ndarray:
    """``g acc_sum`` of one axis on the kinematic rows (``g (a_n + a_{n-1})`` for the ZOH
    conventions): what a readout error scales (``g`` ~ h^2/2)."""
    g = float(np.asarray(_kin_coefficients(data)[2], float)[axis])
    return g * acc_sum(data)[axis]


def switch_series(data: Data, axis: int, lag: int = 0) -> np.ndarray:
    """``-(h^2/2) (f_n - 2 f_(n-1) + f_(n-2))`` of one axis on the kinematic rows (0 where
    n - 2 lies in another segment): the kinematic residual per unit ``tau/h`` of a force
    that switches a time ``tau`` after the sample inside the step.

    Over a step whose force is E on ``[t_n, t_n + s)`` and L after, ``x_(n+1) - x_n - h v_n
    = (h^2/2) Fbar_n + (E - L) s (h - s)/2`` with ``Fbar_n`` the step's mean force (what
    the accelerometer reports); the second difference then leaves ``delta_n - delta_(n-1)``
    over the ZOH relation of :func:`kinematic_target`.  For a delay ``tau = s < h``
    (E = f_(n-1), L = f_n) that is ``-(s (h - s)/2) (f_n - 2 f_(n-1) + f_(n-2))``, i.e. this
    series times ``(tau/h)(1 - tau/h)``: first order in ``tau/h`` (docs/mismatch.md 9.8).
    ``lag = m``: the same for ``tau = m h + s`` (E = f_(n-m-1), L = f_(n-m)), 0 where
    n - m - 2 lies in another segment."""
    n = data.kin_index
    f = data.force[axis]
    g = data.lagged(f, lag)
    d2 = g[n] - 2.0 * g[n - 1] + g[n - 2]
    d2[data.lagged(np.ones_like(f), lag + 2)[n] == 0] = 0.0  # n - lag - 2 in another segment
    return -0.5 * data.dt**2 * d2


def nominal_kinematic_columns(data: Data) -> list[Column]:
    """The nominal kinematics is the exact ZOH relation above; its only free parameters
    are an offset per axis and gap-free segment (an accelerometer bias makes one, and the
    readout's red noise -- double-differenced and shaped by the noise model -- wanders
    across gaps).

    A 3-tap "sampling convention" nuisance was tried and dropped: the readout noise in the
    second difference (2.4e-11 m per sample, blue) determines its taps only to ~0.1, and
    that uncertainty re-enters the residual at the excitation lines (docs/mismatch.md).
    The convention is chosen instead (:func:`choose_acc_convention`).

    With a half-step term (``Data.halfstep``: Euler steps), one correction to it shared by
    every axis is a nuisance (:data:`HALFSTEP_NUISANCE`): the term is chosen at its
    estimate, whose error (~1e-4 of 0.1 on a sub-stepped recording) the whitened
    kinematic group otherwise sees as a readout timing (docs/mismatch.md 9.26).
    """
    cols = []
    for s, (a, b) in enumerate(data.kin_layout.bounds):
        for ax in range(4):
            v = np.zeros((4, data.kin_layout.n))
            v[ax, a:b] = 1.0
            cols.append(Column(f"kin_offset_{AXES[ax]}" + (f"@{s + 1}" if s else ""), v))
    if data.halfstep and HALFSTEP_NUISANCE:
        cols.append(_halfstep_column(data))
    if data.curvature and HALFSTEP_NUISANCE:
        cols.append(_tone_column("kin_curvature", data, curvature_term(data)))
    return cols


#: The shared half-step correction as a nominal kinematic column (False: the term fixed).
HALFSTEP_NUISANCE = True


def halfstep_term(data: Data) -> np.ndarray:
    """The half-step term per unit ``beta``, ``g (a_n - a_{n-1})`` (4, rows), with the
    relation's ``g`` (:func:`kinematic_coefficients`)."""
    n = data.kin_index
    g = np.asarray(_kin_coefficients(data)[2], float)[:, None]
    return g * (data.acc[:, n] - data.acc[:, n - 1])


def curvature_term(data: Data) -> np.ndarray:
    """The curvature term per unit ``lambda``, ``2 g`` times :func:`acc_curvature` (4,
    rows): ``~lambda h^2`` times the accelerations' second difference."""
    g = np.asarray(_kin_coefficients(data)[2], float)[:, None]
    return 2.0 * g * acc_curvature(data)


def _halfstep_column(data: Data) -> Column:
    """:func:`halfstep_term` on every axis's row (:func:`_tone_column`)."""
    return _tone_column("kin_halfstep", data, halfstep_term(data))


def _tone_column(name: str, data: Data, values: np.ndarray) -> Column:
    """A kinematic column on every axis's row with its excitation-tone part as the
    instrument (the loop puts readout noise into the acceleration; an unexcited axis
    adds nothing to it)."""
    time = data.time[data.kin_index]
    inst = np.array([tone_instrument(values[a], time, data.tones(a)) for a in range(4)])
    return Column(name, values, inst)


def tone_instrument(series: np.ndarray, time: np.ndarray, tones: list[float]) -> np.ndarray:
    """The part of ``series`` at the excitation tones (least-squares sines and cosines).

    The excitation is set by the external reference, not by the noise, so this part is a
    valid instrument against closed-loop bias (the reference as instrumental variable);
    without tones it is zero (the axis is not excited).
    """
    return tone_part(series, time, tones)


def tone_part(series: np.ndarray, time: np.ndarray, tones: list[float],
              derivative: bool = False) -> np.ndarray:  # fmt: skip
    """Least-squares fit of ``series`` (N,) by a sine and a cosine per tone [Hz] on
    ``time`` (N,) [s]: the fitted part, or with ``derivative`` its time derivative (each
    tone's pair differentiated exactly); zeros without tones."""
    if not tones:
        return np.zeros_like(series)
    t, w, basis, coef = _tone_fit(series, time, tones)
    if not derivative:
        return basis @ coef
    # d/dt (s sin wt + c cos wt) = w (s cos wt - c sin wt)
    slope = np.column_stack([f(wk * t) for wk in w for f in (np.cos, np.sin)])
    return slope @ (coef * np.repeat(w, 2) * np.tile([1.0, -1.0], len(w)))


@dataclass
class FitResult:
    """Weighted least squares on whitened data: coefficients, covariance, residuals."""

    names: list[str]
    coef: np.ndarray
    cov: np.ndarray
    residual: np.ndarray  # physical units, group shape
    rss_white: float
    n_obs: int

    def std(self) -> np.ndarray:
        return np.sqrt(np.maximum(np.diag(self.cov), 0.0))

    def value(self, name: str) -> float:
        return float(self.coef[self.names.index(name)])

    def sigma(self, name: str) -> float:
        return float(self.std()[self.names.index(name)])


def design(columns: list[Column], whiten) -> tuple[np.ndarray, np.ndarray]:
    """Whitened, column-normalised design matrix (n, p) and the normalisation (p,)."""
    cols = [whiten(c.values).ravel() for c in columns]
    x = np.column_stack(cols) if cols else np.zeros((0, 0))
    scale = np.sqrt(np.mean(x**2, axis=0)) if cols else np.zeros(0)
    scale[scale == 0] = 1.0
    return x / scale, scale


def solve(target: np.ndarray, columns: list[Column], whiten) -> FitResult:
    """Generalised least squares: ``whiten(target) ~ whiten(columns) coef``.

    The covariance is ``s^2 (X'X)^-1`` with ``s^2 = RSS/(n - p)`` in whitened units (the
    noise level is profiled, so a mis-scaled noise model does not distort it).
    """
    yw = whiten(target).ravel()
    if not columns:
        return FitResult([], np.zeros(0), np.zeros((0, 0)), target.copy(), float(yw @ yw),
                         yw.size)  # fmt: skip
    x, scale = design(columns, whiten)
    coef_s, *_ = np.linalg.lstsq(x, yw, rcond=None)
    rw = yw - x @ coef_s
    rss = float(rw @ rw)
    s2 = rss / max(yw.size - x.shape[1], 1)
    cov_s = s2 * np.linalg.pinv(x.T @ x)
    coef = coef_s / scale
    cov = cov_s / np.outer(scale, scale)
    fitted = sum(c * col.values for c, col in zip(coef, columns))
    return FitResult([c.name for c in columns], coef, cov, target - fitted, rss, yw.size)


def solve_iv(target: np.ndarray, columns: list[Column], whiten) -> FitResult:
    """Instrumental-variable estimate on whitened data (just identified).

    ``theta = (Z'X)^-1 Z'y``, heteroscedasticity-consistent covariance ``(Z'X)^-1 Z'
    diag(r^2) Z (X'Z)^-1`` (White 1980: tapered, whitened residuals have a variance that
    follows the taper); a column without an instrument is its own.  Whitening is linear,
    so a valid (noise-independent) instrument stays valid after it.
    """
    yw = whiten(target).ravel()
    if not columns:
        return FitResult([], np.zeros(0), np.zeros((0, 0)), target.copy(), float(yw @ yw),
                         yw.size)  # fmt: skip
    x, scale = design(columns, whiten)
    inst = [Column(c.name, c.values if c.instrument is None else c.instrument) for c in columns]
    z, zscale = design(inst, whiten)
    a = z.T @ x
    ainv = np.linalg.pinv(a)
    coef_s = ainv @ (z.T @ yw)
    rw = yw - x @ coef_s
    rss = float(rw @ rw)
    cov_s = ainv @ ((z * (rw**2)[:, None]).T @ z) @ ainv.T
    coef = coef_s / scale
    cov = cov_s / np.outer(scale, scale)
    fitted = sum(c * col.values for c, col in zip(coef, columns))
    return FitResult([c.name for c in columns], coef, cov, target - fitted, rss, yw.size)


def output_error(data: Data, basis: np.ndarray, eq_fitted: np.ndarray) -> np.ndarray:
    """Open-loop replay of the f_B-free positions ``q = N' x`` (2, N): measured - replayed.

    The replay double-integrates (ZOH, exact for held forces) the *model* acceleration
    ``N' f + fitted(N' (acc - f))`` of the identified model, driven by the recorded
    commanded forces; initial position and velocity are fitted by least squares, per
    gap-free segment (a replay cannot cross a gap).  f_B cancels in these combinations,
    so no unknown input is needed.  Integrated actuation and accelerometer noise make this
    residual red (random walk): it is a diagnostic of the replay, not the statistic of
    the tests.
    """
    h = data.dt
    model_acc = basis.T @ data.force + eq_fitted
    q = basis.T @ data.x
    out = np.empty_like(q)
    for a, b in data.segments:
        ma = model_acc[:, a:b]
        vel = np.concatenate([np.zeros((2, 1)), np.cumsum(ma[:, :-1] * h, axis=1)], axis=1)
        pos = np.concatenate([np.zeros((2, 1)),
                              np.cumsum(vel[:, :-1] * h + 0.5 * ma[:, :-1] * h * h, axis=1)],
                             axis=1)  # fmt: skip
        t = data.time[a:b] - data.time[a]
        basis_ic = np.column_stack([np.ones_like(t), t])
        for j in range(2):
            c, *_ = np.linalg.lstsq(basis_ic, q[j, a:b] - pos[j], rcond=None)
            out[j, a:b] = q[j, a:b] - pos[j] - basis_ic @ c
    return out


def align_kinematics(data: Data, max_lag: int = 2) -> Data:
    """Pair the displacement readouts with the accelerations they belong to.

    The kinematic check needs x and acc on one clock; a recorder that stamps one of them a
    whole sample off breaks it by the motion's step-to-step change.  The integer lag of x
    in ``[-max_lag, max_lag]`` that minimises the kinematic residual of the excited
    sensitive axes is taken if it divides it by ``ALIGN_GAIN`` (a note says so).
    """
    rms = {}
    for lag in range(-max_lag, max_lag + 1):
        d = _shifted(data, lag, "x")
        if d.n - 2 * len(d.segments) < 16:
            continue
        rms[lag] = float(np.sqrt(np.mean(kinematic_target(d)[:2] ** 2)))
    if not rms or 0 not in rms:
        return data
    best = min(rms, key=rms.get)
    if best == 0 or rms[0] < ALIGN_GAIN * rms[best]:
        return data
    out = _shifted(data, best, "x")
    side = "late" if best > 0 else "early"
    out.notes.append(
        f"the displacement readouts are stamped {abs(best)} sample(s) {side} relative to the "
        f"accelerations (kinematic residual {rms[0]:.3g} -> {rms[best]:.3g} m when aligned); "
        "they were aligned before the diagnosis")  # fmt: skip
    return out


def choose_acc_convention(data: Data, k: np.ndarray,
                          nuisance: Sequence[Column] = ()) -> tuple[str, dict]:  # fmt: skip
    """Which accelerometer sampling convention the recording follows (``held``, ``mean``
    or ``end``).

    ``held`` (``a_n = k r(t_n) + u_n``), ``mean`` (the mean over ``[t_n, t_{n+1})``) and
    ``end`` (``k r(t_{n+1}) + u_n``: read after the step) differ in Eq. 10 by the stiffness
    term, ``~k v h/2`` apart: the nominal least-squares fit of Eq. 10 with ``x_n``,
    ``(x_n + x_{n+1})/2`` or ``x_{n+1}`` is compared by the likelihood ratio
    ``LR_c = n log(RSS_c / RSS_best)``; a convention stays in the running while its LR
    is below ``DECIDE_LR``, and one left alone decides.  That term is in step with the
    motion, and a wrong convention makes it look like an actuation delay -- and a delay
    can make a wrong convention look right.  So the LRs are first taken with the 1-tap
    delay columns (:func:`_step_mean_columns`) as nuisance in all fits (what a delay
    cannot explain).  If ``held`` and ``mean`` are both left, the LR between those two
    without the delay columns decides as before (the delay-free test loses power where
    the controller makes the terms alike; docs/mismatch.md 9.8) -- but never for ``end``:
    a delay moves that pass, and ``end`` lies twice as far from ``held`` as ``mean``
    does (a true 0.011 s delay on a ``held`` recording reads ``mean`` at LR 10.6 there,
    ``end`` at 47; docs/mismatch.md 9.25).  Of several left, the equation group cannot
    tell them apart (the difference is below the noise) and the kinematic evidence
    decides (:func:`_kinematic_convention`); failing that, ``held`` if it is left (as
    before), else the one left that fits the equation best.
    The recording's ``acc_sampling`` attribute, when present, decides instead.
    ``nuisance``: further Eq. 10 columns in all fits -- the selected effects' when the
    diagnosis redoes its kinematics with the final model (an unmodelled gain or coupling
    in step with the motion otherwise decides between the stiffness terms).
    ``info``: ``equation_lr_mean_vs_held`` and ``equation_lr_end_vs_held`` (positive:
    ``held`` fits worse), each with ``_delay_free`` for the first pass; ``left``: the
    conventions the equation group left undecided (absent where it or the half-step
    term decided).
    """
    if data.usage.get("acc_convention_from") == "attribute":
        return data.acc_convention, {"from": "attribute", "halfstep": data.halfstep}
    basis = null_basis(data.geometry)
    info: dict = {"halfstep": 0.0}
    beta, info["halfstep_evidence"] = _halfstep(data, k)
    if beta:  # Euler steps record the acceleration at the sample: Eq. 10 then allows held
        rss = _equation_rss(data, basis, ACC_CONVENTIONS, DELAY_NUISANCE, nuisance)
        info["equation_lr_held_vs_best"] = _lr(data, rss["held"], min(rss.values()))
        held = info["equation_lr_held_vs_best"] < DECIDE_LR
        # an integrating readout (the step's mean, ~r(t_n - h/2)) is the explicit term
        # exactly, and its readouts sit half a step from the accelerometer's k r term:
        # Eq. 10's stiffness term then reads them where it fits best (docs/mismatch.md
        # 9.27).  Other terms are Euler sub-steps, whose accelerometer is held
        integrating = beta == -1.0 and INTEGRATING_READOUT
        if held or integrating:
            info.update(halfstep=beta, decided=True, by="kinematic group (half-step term)")
            if held:
                return "held", info
            info["by"] += "; stiffness term placed by the equation group"
            return min(rss, key=rss.get), info
    left, fittest = list(ACC_CONVENTIONS), "held"
    passes = [(True, left)] if DELAY_NUISANCE else []
    for delay, among in passes + [(False, ["held", "mean"])]:
        if not set(among) <= set(left):  # the second pass: only while held and mean are left
            break
        rss = _equation_rss(data, basis, among, delay, nuisance)
        suffix = "_delay_free" if delay else ""
        for conv in ("mean", "end"):
            if conv in rss and "held" in rss:
                info[f"equation_lr_{conv}_vs_held{suffix}"] = _lr(data, rss["held"], rss[conv])
        best = min(rss, key=rss.get)
        kept = [c for c in among if _lr(data, rss[c], rss[best]) < DECIDE_LR]
        if len(kept) == 1:
            info["decided"] = True
            info["by"] = "equation group" + (" (delay columns as nuisance)" if delay else "")
            return kept[0], info
        if delay:
            left, fittest = kept, best
    # undecided: held if it is left (as before), else the one that fits the equation best
    conv, kin = _kinematic_convention(data, k, left, "held" if "held" in left else fittest)
    info.update(kin)
    info["left"] = list(left)  # what the equation group could not tell apart
    return conv, info


def _lr(data: Data, rss_worse: float, rss_better: float) -> float:
    """``n log(RSS_a / RSS_b)`` over both Eq. 10 combinations' samples."""
    return 2 * data.n * math.log(rss_worse / rss_better)


def _equation_rss(data: Data, basis: np.ndarray, conventions: Sequence[str], delay: bool,
                  nuisance: Sequence[Column]) -> dict[str, float]:  # fmt: skip
    """The nominal Eq. 10 fit's residual sum of squares under each convention (the 1-tap
    delay columns and ``nuisance`` beside the nominal columns)."""
    rss = {}
    for conv in conventions:
        # a half-step term goes with held (the true position's relation keeps it)
        probe = replace(data, acc_convention=conv, notes=[],
                        halfstep=data.halfstep if conv == "held" else 0.0)  # fmt: skip
        probe.__dict__.pop("_x_eq", None)
        cols = nominal_equation_columns(probe, basis)
        cols += _step_mean_columns(probe, basis) if delay else []
        cols += list(nuisance)
        fit = solve(equation_target(probe, basis), cols, lambda v: v)
        rss[conv] = max(float(np.sum(fit.residual**2)), 1e-300)
    return rss


#: |LR| (chi^2_1 units) above which the equation group decides the convention (p ~ 2e-3).
DECIDE_LR = 10.0
#: Try the convention's LR with the delay columns as nuisance first (False: r7's test).
DELAY_NUISANCE = True


def _step_mean_columns(data: Data, basis: np.ndarray) -> list[Column]:
    """Per axis ``f_(n-1) - f_n`` (0 across a gap): what a sub-sample actuation delay adds
    to the step-mean force (the 1-tap column of ``effects/actuation_delay.py``)."""
    out = []
    for i in range(4):
        f = data.force[i]
        d = data.lagged(f, 1) - f
        d[data.lagged(np.ones_like(f), 1) == 0] = 0.0
        out.append(Column(f"step_mean_{AXES[i]}", axis_column(basis, i, d)))
    return out


#: A half-step term is taken (:func:`_halfstep`) when its combined estimate is
#: HALFSTEP_Z standard errors from 0, at least two axes see it (HALFSTEP_AXIS_Z each) and
#: every excited axis agrees (within 4 of its standard errors and HALFSTEP_SLACK of the
#: value).  A readout stamped ``tau`` late on one axis has ``beta = -2 tau/h`` there and
#: 0 elsewhere, so it is never taken (on the 240000 benchmark draw, readout timings and a
#: clipped accelerometer reach 13-40 standard errors on one axis); the two-axis rule is
#: the guard, the combined one (7: two axes at 5 make ~7) its consequence
#: (docs/mismatch.md 9.26).
HALFSTEP_Z = 7.0
HALFSTEP_AXIS_Z = 5.0
HALFSTEP_SLACK = 0.02


def _halfstep(data: Data, k: np.ndarray) -> tuple[float, dict]:
    """The kinematic relation's half-step coefficient ``beta`` (0: the ZOH relations).

    Under ``held`` with the equation group's ``k``, the residual of a recording whose
    relation has half-step ``beta`` is ``|beta|`` times the change from ``beta = 0`` to
    ``sign(beta)`` (:func:`kinematic_coefficients`: the term and its k coefficients;
    affine in ``|beta|`` to O(k h^2)); ``beta`` is estimated per excited axis
    (:func:`_halfstep_fit`) and taken by the rule of :data:`HALFSTEP_Z`.  At a tone of
    angular frequency w the ZOH conventions' stiffness terms look like a half-step of
    ``~k/w^2`` (1e-2 for a 500 s tone at k 2e-6, more for slower ones), so a term is
    taken only if it is also seen against ``mean`` and ``end``: a recording that one of
    the ZOH relations fits has none.  Returns ``beta`` (snapped to +-1 within 3 standard
    errors and :data:`HALFSTEP_SLACK`) or 0, and the evidence: per axis and ``combined``
    under ``held``, and the
    ``combined`` of the others (``vs_mean``, ``vs_end``).
    """
    info: dict = {}
    if not HALFSTEP:
        return 0.0, info
    rows, info = _halfstep_fit(data, k, "held")
    if not rows:
        return 0.0, info
    beta, se = info["combined"]["beta"], info["combined"]["se"]
    if not _term_taken(rows, beta, se) or abs(beta) > 1.0 + 3.0 * se:
        return 0.0, info
    for conv in ACC_CONVENTIONS:
        if conv != "held":
            other = _halfstep_fit(data, k, conv)[1]["combined"]
            info[f"vs_{conv}"] = other
            if abs(other["beta"]) < HALFSTEP_Z * other["se"]:
                return 0.0, info
    # snapped within 3 standard errors and HALFSTEP_SLACK: an integrating readout's
    # curvature moves the estimate by ~lambda (w h)^2 (-0.9986 at 2 Hz; 9.27), and N >= 2
    # sub-steps give |beta| <= 1/2
    slack = HALFSTEP_SLACK if INTEGRATING_READOUT else 0.0
    near = abs(abs(beta) - 1.0) < 3.0 * se + slack
    return (math.copysign(1.0, beta) if near else beta), info


def _halfstep_fit(data: Data, k: np.ndarray, convention: str) -> tuple[list, dict]:
    """Per excited axis, the half-step coefficient of the residual under ``convention``
    (with ``k``) by instrumental variables (the excitation tones: the loop puts readout
    noise into the acceleration), its standard error from the residual beside the tones
    (:func:`sideband_se`); and their inverse-variance ``combined``.  Under ``held`` the
    regressor is the change of the whole relation to ``beta = +-1`` (the side read from
    the term alone), under the others the term ``g (a_n - a_{n-1})`` itself."""
    probe = replace(data, stiffness=np.asarray(k, float), acc_convention=convention,
                    halfstep=0.0, notes=[])  # fmt: skip
    probe.__dict__.pop("_tones", None)
    y0 = kinematic_target(probe)
    n = data.kin_index
    if convention == "held":
        step = {s: y0 - kinematic_target(replace(probe, halfstep=s)) for s in (1.0, -1.0)}
    else:
        term = halfstep_term(probe)
        step = {1.0: term, -1.0: -term}
    rows, info = [], {}
    for a in range(4):
        tones = data.tones(a)
        if not tones:
            continue
        up = float(tone_instrument(step[1.0][a], data.time[n], tones) @ y0[a]) >= 0
        sign = 1.0 if up else -1.0
        reg = step[sign][a]
        z = tone_instrument(reg, data.time[n], tones)
        zz = float(z @ reg)
        if zz == 0:
            continue
        size = float(z @ y0[a]) / zz  # |beta| on that side
        se = sideband_se(z, y0[a] - size * reg, data.time[n]) / abs(zz)
        rows.append((sign * size, se))
        info[AXES[a]] = {"beta": sign * size, "se": se}
    info["combined"] = _combined(rows, "beta")
    return rows, info


#: Estimate a curvature term from the data (:func:`choose_curvature`); False: stop 50's tool.
CURVATURE = True
#: Largest curvature taken: the trapezoid of two samples has 1/4, a step's mean 1/6, a
#: smooth acceleration sampled at the instants 1/12; beyond 1/2 no averaging makes it.
CURVATURE_MAX = 0.5


def choose_curvature(data: Data) -> tuple[float, dict]:
    """The kinematic relation's curvature coefficient ``lambda`` (0: none), with
    ``data``'s convention and half-step term (:func:`acc_curvature`; docs/mismatch.md 9.27).

    ``lambda`` is estimated per excited axis by instrumental variables (the tones), its
    standard error from the residual beside them (:func:`sideband_se`), and taken by the
    half-step term's rule (:data:`HALFSTEP_Z`: two axes see it, every excited axis
    agrees, the combined estimate is far from 0) when ``0 < lambda <= CURVATURE_MAX``.
    At a tone of angular frequency w the term is a gain ``-lambda (w h)^2`` of the
    relation, so a readout scale ``e`` on one axis looks like ``lambda = -e/(w h)^2``
    there: one axis never decides, and a scale shared by the axes reads a different
    ``lambda`` on each unless their tones sit at one frequency (then it is taken for a
    curvature: the limit of this test).  Returns ``lambda`` or 0, and the evidence."""
    if not CURVATURE:
        return 0.0, {}
    probe = replace(data, curvature=0.0, notes=[])
    probe.__dict__.pop("_x_eq", None)
    y0 = kinematic_target(probe)
    reg = curvature_term(probe)
    rows, info = _iv_rows(data, y0, reg, "lambda", _curvature_instrument(probe))
    if not rows:
        return 0.0, info
    lam, se = info["combined"]["lambda"], info["combined"]["se"]
    if not _term_taken(rows, lam, se) or lam <= 0 or lam > CURVATURE_MAX + 3.0 * se:
        return 0.0, info
    return lam, info


def _curvature_instrument(data: Data) -> np.ndarray:
    """The curvature term's instrument (4, rows): each tone of the acceleration passed
    through the term's filter.  The term's own tone part is a poorer one: the second
    difference lifts the loop's broadband force (readout noise fed back) by ``16/(w h)^2``
    against the tones, and what of it leaks into a tone fit is noise, correlated with the
    readout noise in the target -- on clean integrating-readout recordings at 8-10 Hz its
    standard errors were up to 5 times these, and two estimates sat 2 of them above 1/6
    (docs/mismatch.md 9.27)."""
    n, h = data.kin_index, data.dt
    g = np.asarray(_kin_coefficients(data)[2], float)
    w = 0.5 * (1.0 + float(data.halfstep))  # the weight of c_n (:func:`acc_curvature`)

    def response(om: float) -> complex:
        return (2 * math.cos(om * h) - 2) * (w + (1 - w) * complex(math.cos(om * h),
                                                                    -math.sin(om * h)))

    time = data.time[n]
    return np.array([2 * g[a] * tone_response(data.acc[a, n], time, data.tones(a), response)
                     for a in range(4)])  # fmt: skip


def _tone_fit(series: np.ndarray, time: np.ndarray, tones: list[float]):
    """Least squares by a sine and a cosine per tone: ``(t, w, basis, coef)`` with ``t``
    from the first sample, ``w`` the angular frequencies, ``coef`` (sin, cos) per tone."""
    t = time - time[0]
    w = [2 * math.pi * f0 for f0 in tones]
    basis = np.column_stack([f(wk * t) for wk in w for f in (np.sin, np.cos)])
    coef, *_ = np.linalg.lstsq(basis, series, rcond=None)
    return t, w, basis, coef


def tone_response(series: np.ndarray, time: np.ndarray, tones: list[float],
                  response) -> np.ndarray:  # fmt: skip
    """:func:`tone_part` of ``series`` with each tone passed through a linear filter of
    complex frequency response ``response(w)`` (``sum_j h_j e^{-i w j dt}`` for ``y_n =
    sum_j h_j x_{n-j}``): amplitude times ``|H|``, phase advanced by ``arg H``."""
    if not tones:
        return np.zeros_like(series)
    t, w, _, coef = _tone_fit(series, time, tones)
    out = np.zeros_like(series)
    for k, wk in enumerate(w):
        hk = response(wk)
        amp, ph = abs(hk), math.atan2(hk.imag, hk.real)
        out += amp * (coef[2 * k] * np.sin(wk * t + ph) + coef[2 * k + 1] * np.cos(wk * t + ph))
    return out


def _iv_rows(data: Data, y0: np.ndarray, reg: np.ndarray, name: str,
             instrument: np.ndarray) -> tuple[list, dict]:  # fmt: skip
    """Per excited axis the coefficient of ``reg`` in ``y0`` (both (4, rows)) by
    instrumental variables (``instrument``, the tones' part, Hann-tapered per segment as
    the kinematic group is) with its sideband standard error; and their inverse-variance
    ``combined``.  The taper keeps a segment's first rows out: a simulator's start-up
    (its first readout a point, then step means) left one row 1e3 times the others that
    took the estimate to 0."""
    n = data.kin_index
    win = np.concatenate([taper(b - a, 1.0) for a, b in data.kin_layout.bounds])
    rows, info = [], {}
    for a in range(4):
        tones = data.tones(a)
        if not tones:
            continue
        z = instrument[a] * win
        zz = float(z @ reg[a])
        if zz == 0:
            continue
        c = float(z @ y0[a]) / zz
        se = sideband_se(z, y0[a] - c * reg[a], data.time[n]) / abs(zz)
        rows.append((c, se))
        info[AXES[a]] = {name: c, "se": se}
    info["combined"] = _combined(rows, name)
    return rows, info


def _combined(rows: list, name: str) -> dict:
    if not rows:
        return {name: 0.0, "se": math.inf}
    b, s = np.array(rows).T
    w = 1.0 / np.maximum(s, 1e-300) ** 2
    return {name: float(np.sum(w * b) / np.sum(w)), "se": float(1.0 / math.sqrt(np.sum(w)))}


def _term_taken(rows: list, value: float, se: float) -> bool:
    """The rule of a relation term estimated per axis (:data:`HALFSTEP_Z`)."""
    b, s = np.array(rows).T
    seen = int(np.sum(np.abs(b) > HALFSTEP_AXIS_Z * s))
    agree = bool(np.all(np.abs(b - value) < 4.0 * s + HALFSTEP_SLACK * abs(value)))
    return abs(value) >= HALFSTEP_Z * se and seen >= 2 and agree


#: Sideband offsets (in units of 1/T) of :func:`sideband_se`: clear of a tone's main lobe.
SIDEBANDS = tuple(range(3, 15))


def sideband_se(z: np.ndarray, res: np.ndarray, time: np.ndarray) -> float:
    """Standard deviation of ``z @ res`` for a tone instrument ``z`` and coloured ``res``:
    the spread of the same projection with ``z`` moved off its tones by ``+-m/T``
    (``z cos(2 pi m t/T)``, rescaled to ``z``'s norm), ``m`` in :data:`SIDEBANDS` -- the
    residual's own noise beside the tones, where a white formula would take its (blue)
    mean square."""
    t = time - time[0]
    span = float(t[-1]) + (float(t[1] - t[0]) if t.size > 1 else 1.0)
    zz = float(z @ z)
    proj = []
    for m in SIDEBANDS:
        zm = z * np.cos(2 * math.pi * m * t / span)
        norm = float(zm @ zm)
        if norm > 0:
            proj.append(float(zm @ res) * math.sqrt(zz / norm))
    return float(np.sqrt(np.mean(np.square(proj)))) if proj else math.inf


def _kinematic_convention(data: Data, k: np.ndarray, left: Sequence[str] = ACC_CONVENTIONS,
                          default: str = "held") -> tuple[str, dict]:  # fmt: skip
    """The kinematic evidence among the conventions ``left``: the exact relations differ
    by ``~k h^2/2 (x_n - x_{n-1})``; its coefficient ``gamma`` is estimated on the
    sensitive axes by instrumental variables (the excitation tones): ``held`` predicts
    gamma = k, ``mean`` gamma ~ 0, ``end`` gamma = -k; decided (the least squared
    misfit) when the predictions are 2 standard errors apart, else ``default``."""
    info: dict = {}
    predicted = {"held": 1.0, "mean": 0.0, "end": -1.0}  # gamma / k
    probe = replace(data, stiffness=np.zeros(4), acc_convention="mean", halfstep=0.0,
                    notes=[])  # fmt: skip
    probe.__dict__.pop("_tones", None)
    y = kinematic_target(probe)
    n = data.kin_index
    h2 = data.dt**2
    votes = []
    for a in (0, 1):
        tones = data.tones(a)
        if not tones:
            continue
        reg = 0.5 * h2 * (data.x[a, n] - data.x[a, n - 1])
        z = tone_instrument(reg, data.time[n], tones)
        zz = float(z @ reg)
        if zz == 0:
            continue
        gam = float(z @ y[a]) / zz
        res = y[a] - gam * reg
        se = math.sqrt(float(np.mean(res**2)) * float(z @ z)) / abs(zz)
        votes.append((gam, se, float(k[a])))
        info[AXES[a]] = {"gamma": gam, "se": se, "k": float(k[a])}
    decisive = [(g, s, kk) for g, s, kk in votes if abs(kk) > 2 * s]
    if not decisive or len(left) < 2:
        info["decided"] = False
        return default, info
    score = {c: sum(((g - predicted[c] * kk) / s) ** 2 for g, s, kk in decisive) for c in left}
    info["decided"] = True
    info["by"] = "kinematic group"
    return min(left, key=lambda c: (score[c], c != default)), info
