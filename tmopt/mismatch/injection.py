"""Generator-side physical effects: how each catalogue effect is *made* in the simulator.

The diagnosis tool's catalogue (``effects.py``) explains recordings; this module conceals
effects in them.  Each :class:`EffectModel` turns an :class:`Injection` (name, magnitude
in physical units, channel, onset/duration, options) into the simulator's generic hooks
(:class:`tmopt.physics.simulator.Perturbations`), a changed true geometry, or a transform
of a recorded sensor channel, and reports the true parameters for the truth file.  The
physics of each effect, its parameters and allowed ranges are in its class docstring and
in ``docs/mismatch-generator.md``.

Times (``onset``, ``duration``) are in seconds from the first sample.  Magnitudes outside an
effect's range raise ``ValueError`` naming the effect, the parameter and the range.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from tmopt.physics.geometry import Geometry
from tmopt.physics.simulator import Perturbations

__all__ = ["AXES", "Injection", "Builder", "EffectModel", "EFFECTS", "EFFECT_NAMES",
           "glitch_interval_average", "coloured_noise"]  # fmt: skip

AXES: tuple[str, ...] = ("x1", "x2", "y1", "y2")
#: The other in-plane axis of the same test mass.
PARTNER = {"x1": "y1", "y1": "x1", "x2": "y2", "y2": "x2"}


@dataclass(frozen=True)
class Injection:
    """One concealed effect.  ``channel`` None = the effect's default; ``onset``/``duration``
    [s] window the effect where meaningful (None = effect default); ``options`` are
    effect-specific (see each :class:`EffectModel`)."""

    name: str
    magnitude: float
    channel: str | None = None
    onset: float | None = None
    duration: float | None = None
    options: Mapping[str, Any] = field(default_factory=dict)


class Builder:
    """Accumulates the hooks of all injections of one recording (N samples at ``fs``)."""

    def __init__(self, n: int, fs: float, geometry: Geometry, seed: int) -> None:
        self.n, self.fs, self.seed = n, fs, seed
        self.time = np.arange(n) / fs
        self.geometry = geometry  # the *true* geometry (geometry_error changes it)
        self.fields: dict[str, np.ndarray] = {}
        self.post: list[Callable[[dict[str, np.ndarray]], None]] = []

    @property
    def duration(self) -> float:
        return self.n / self.fs

    def series(self, name: str, rows: int) -> np.ndarray:
        if name not in self.fields:
            self.fields[name] = np.zeros((rows, self.n))
        return self.fields[name]

    def const(self, name: str, init: np.ndarray) -> np.ndarray:
        """A constant hook array, created from ``init`` on first use, shared afterwards."""
        if name not in self.fields:
            self.fields[name] = np.array(init, dtype=np.float64)
        return self.fields[name]

    def perturbations(self) -> Perturbations | None:
        if not self.fields:
            return None
        kw = {k: (tuple(v) if v.ndim == 1 else v) for k, v in self.fields.items()}
        return Perturbations(**kw)


class EffectModel:
    """Base: ``inject`` adds the effect to a :class:`Builder` and returns its true parameters.

    Class attributes: ``name`` (catalogue name), ``parameter`` and ``unit`` (what the
    magnitude is), ``limit`` (allowed ``|magnitude|``), ``signed`` (negative allowed),
    ``channels`` and ``default_channel``, ``windowed`` (onset/duration meaningful),
    ``options`` (defaults of the effect-specific options).
    """

    name: ClassVar[str]
    parameter: ClassVar[str]
    unit: ClassVar[str]
    limit: ClassVar[float]
    signed: ClassVar[bool] = True
    channels: ClassVar[tuple[str, ...]] = AXES
    default_channel: ClassVar[str] = "x1"
    windowed: ClassVar[bool] = False
    options: ClassVar[dict[str, Any]] = {}

    def check(self, inj: Injection, duration: float) -> tuple[str, dict[str, Any]]:
        """Validate magnitude, channel, window and options; return channel and options."""
        m = inj.magnitude
        if isinstance(m, bool) or not isinstance(m, (int, float)) or not math.isfinite(m):
            raise ValueError(f"{self.name}: magnitude ({self.parameter}) must be a finite "
                             f"number; got {m!r}")  # fmt: skip
        lo = -self.limit if self.signed else 0.0
        if not lo <= m <= self.limit:
            raise ValueError(f"{self.name}: magnitude ({self.parameter}) must be in "
                             f"[{lo:g}, {self.limit:g}] {self.unit}; got {m!r}")  # fmt: skip
        ch = self.default_channel if inj.channel is None else inj.channel
        if ch not in self.channels:
            raise ValueError(f"{self.name}: channel must be one of {list(self.channels)}; "
                             f"got {ch!r}")  # fmt: skip
        unknown = set(inj.options) - set(self.options)
        if unknown:
            raise ValueError(f"{self.name}: unknown option(s) {sorted(unknown)}; allowed "
                             f"{sorted(self.options)}")  # fmt: skip
        if not self.windowed and (inj.onset is not None or inj.duration is not None):
            raise ValueError(f"{self.name}: onset/duration are not meaningful for this effect")
        _check_window(self.name, inj, duration)
        return ch, {**self.options, **dict(inj.options)}

    def window(self, inj: Injection, b: Builder, onset: float = 0.0,
               length: float | None = None) -> tuple[float, float]:  # fmt: skip
        """(onset, end) [s] of the effect, from the injection or the given defaults."""
        t0 = onset if inj.onset is None else float(inj.onset)
        span = length if inj.duration is None else float(inj.duration)
        return t0, (math.inf if span is None else t0 + span)

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        raise NotImplementedError


def _check_window(name: str, inj: Injection, duration: float) -> None:
    if inj.onset is not None and not (math.isfinite(inj.onset) and 0 <= inj.onset < duration):
        raise ValueError(f"{name}: onset must be in [0, {duration:g}) s; got {inj.onset!r}")
    if inj.duration is not None and not (math.isfinite(inj.duration) and inj.duration > 0):
        raise ValueError(f"{name}: duration must be in (0, inf) s; got {inj.duration!r}")


def _option(name: str, key: str, value: Any, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
        raise ValueError(f"{name}: option {key!r} must be a number in [{lo:g}, {hi:g}]; "
                         f"got {value!r}")  # fmt: skip
    return float(value)


def _ramp(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """``clip(t - t0, 0, t1 - t0)``: a linear change from t0, held after t1."""
    return np.clip(t - t0, 0.0, t1 - t0)


def _ramp_average(t: np.ndarray, h: float, t0: float, t1: float) -> np.ndarray:
    """Exact average of :func:`_ramp` over each ``[t_n, t_n + h)``.

    Antiderivative of ``clip(s - t0, 0, L)`` (L = t1 - t0): ``u^2/2 + L max(s - t1, 0)``
    with ``u = clip(s - t0, 0, L)`` (the second term is absent when t1 is infinite).
    """
    span = t1 - t0

    def g(s: np.ndarray) -> np.ndarray:
        u = np.clip(s - t0, 0.0, span)
        tail = span * np.maximum(s - t1, 0.0) if math.isfinite(span) else 0.0
        return 0.5 * u**2 + tail

    return (g(t + h) - g(t)) / h


# --------------------------------------------------------------------------- actuation


class ActuationGain(EffectModel):
    """Electrode drive gain error: applied force ``(1 + g) f_cmd`` on one axis from
    ``onset`` for ``duration`` (default: the whole run).  The commanded force channel is
    unchanged; the acceleration channel sees the applied force."""

    name, parameter, unit, limit, windowed = "actuation_gain", "g", "1", 0.5, True

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        t0, t1 = self.window(inj, b)
        gain = b.series("actuation_gain", 4)
        gain[AXES.index(ch)] += inj.magnitude * ((b.time >= t0) & (b.time < t1))
        return {"g": inj.magnitude, "onset_s": t0, "end_s": _finite(t1)}


class ActuationDelay(EffectModel):
    """Actuation latency: the applied force is the command held (ZOH) and delayed by tau;
    fractional delays are exact (the simulator splits the step at ``t_n + (tau mod h)``)."""

    name, parameter, unit, limit, signed = "actuation_delay", "tau", "s", 10.0, False

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        delay = b.const("actuation_delay", np.zeros(4))
        delay[AXES.index(ch)] += inj.magnitude
        return {"tau": inj.magnitude}


class ActuationQuantisation(EffectModel):
    """DAC resolution: the applied force is ``q floor(f/q + 1/2)`` (round half up) of the
    (delayed) command, before any gain error; channel ``all`` quantises all four axes."""

    name, parameter, unit, limit = "actuation_quantisation", "q", "m s^-2", 1e-8
    signed = False
    channels = AXES + ("all",)

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        step = b.const("actuation_step", np.zeros(4))
        for a in range(4) if ch == "all" else [AXES.index(ch)]:
            step[a] = inj.magnitude
        return {"q": inj.magnitude, "rounding": "half up"}


# --------------------------------------------------------------------------- stiffness


class StiffnessCrossCoupling(EffectModel):
    """Off-diagonal stiffness (Sec. 2.2 neglects it): force ``k_ab r_b`` in the equation of
    axis a (``channel``) from axis b (option ``source``, default the other in-plane axis
    of the same test mass).  Under the paper's excitation y is held at zero, so
    ``x<-y`` is nearly invisible while ``y<-x`` is driven by the x motion."""

    name, parameter, unit, limit = "stiffness_cross_coupling", "k_ab", "s^-2", 1e-5
    options = {"source": None}

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        src = PARTNER[ch] if opt["source"] is None else opt["source"]
        if src not in AXES or src == ch:
            raise ValueError(f"{self.name}: option 'source' must be one of "
                             f"{[a for a in AXES if a != ch]}; got {src!r}")  # fmt: skip
        coupling = b.const("stiffness_coupling", np.zeros((4, 4)))
        coupling[AXES.index(ch), AXES.index(src)] += inj.magnitude
        return {f"k_{ch}{src}": inj.magnitude, "source": src, "tool_channel": f"{ch}<-{src}"}


class CubicStiffness(EffectModel):
    """Non-linear force gradient ``k3 r^3`` on one axis (odd term of the force's Taylor
    series; a plausible electrostatic value k/D^2 ~ 6e-3 m^-2 s^-2 is far below what the
    1e-5 m motions reveal, so visible magnitudes are large)."""

    name, parameter, unit, limit = "cubic_stiffness", "k3", "m^-2 s^-2", 1e8

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        b.const("cubic_stiffness", np.zeros(4))[AXES.index(ch)] += inj.magnitude
        return {"k3": inj.magnitude}


class StiffnessDrift(EffectModel):
    """Stiffness drifting linearly: ``k(t) = k + kdot clip(t - onset, 0, duration)``
    (defaults: from t = 0 to the end).  The stiffness at the record's midpoint is
    reported too, since a fit with ``kdot (t - t_mid)`` absorbs the offset into k."""

    name, parameter, unit, limit, windowed = "stiffness_drift", "kdot", "s^-3", 1e-8, True

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        t0, t1 = self.window(inj, b)
        # held at its t_n value over each step, like every state-dependent perturbation
        b.series("stiffness_change", 4)[AXES.index(ch)] += inj.magnitude * _ramp(b.time, t0, t1)
        mid = float(inj.magnitude * _ramp(np.array([b.time[-1] / 2]), t0, t1)[0])
        return {"kdot": inj.magnitude, "onset_s": t0, "end_s": _finite(t1),
                "dk_at_mid": mid}  # fmt: skip


class BiasDrift(EffectModel):
    """Bias force drifting linearly: ``f_D(t) = f_D + fdot clip(t - onset, 0, duration)``,
    applied as its exact average over each sampling interval."""

    name, parameter, unit, limit, windowed = "bias_drift", "fdot", "m s^-3", 1e-11, True

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        t0, t1 = self.window(inj, b)
        avg = _ramp_average(b.time, 1.0 / b.fs, t0, t1)
        b.series("force", 4)[AXES.index(ch)] += inj.magnitude * avg
        return {"fdot": inj.magnitude, "onset_s": t0, "end_s": _finite(t1)}


def _finite(t: float) -> float | None:
    return t if math.isfinite(t) else None


# --------------------------------------------------------------------------- spacecraft


class RotationCoupling(EffectModel):
    """Spacecraft rotation: Eq. 1's ``rho x w' + 2 rho' x w + w x (rho x w)`` at each TM
    (lever arms of the 0.4 m layout), with the rate and angular acceleration written to
    the ``sc_omega*`` witness channels (exact, frame s).  ``channel`` = body axis of the
    rotation (``omega_x|y|z``); magnitude = peak rate [rad s^-1].  Profiles (option
    ``profile``): ``slew`` -- ``w = W sin^2(pi (t - onset)/D)`` over [onset, onset + D]
    (defaults onset = T/4, D = T/2), a smooth attitude manoeuvre; ``jitter`` -- a sum of
    24 random-phase tones log-spaced in [2/T, 0.05 Hz] with equal rate amplitudes, scaled
    to peak ``W`` (slow attitude jitter); w' is the exact derivative in both."""

    name, parameter, unit, limit = "rotation_coupling", "omega_peak", "rad s^-1", 1e-4
    windowed = True
    channels = ("omega_x", "omega_y", "omega_z")
    default_channel = "omega_z"
    options = {"profile": "slew"}

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        j = "xyz".index(ch[-1])
        if opt["profile"] == "slew":
            t0, t1 = self.window(inj, b, onset=b.duration / 4, length=b.duration / 2)
            w, wd = _slew(b.time, t0, min(t1, b.duration), inj.magnitude)
            window = {"onset_s": t0, "end_s": min(t1, b.duration)}
        elif opt["profile"] == "jitter":
            if inj.onset is not None or inj.duration is not None:
                raise ValueError(f"{self.name}: the jitter profile lasts the whole run "
                                 "(no onset/duration)")  # fmt: skip
            w, wd = _jitter(b.time, inj.magnitude, b.seed, j)
            window = {}
        else:
            raise ValueError(f"{self.name}: option 'profile' must be 'slew' or 'jitter'; "
                             f"got {opt['profile']!r}")  # fmt: skip
        b.series("omega", 3)[j] += w
        b.series("omega_dot", 3)[j] += wd
        geo = b.geometry
        return {"omega_peak": inj.magnitude, "axis": ch[-1], "profile": opt["profile"],
                "r01_s": geo.r01_s.tolist(), "r02_s": geo.r02_s.tolist(),
                "r12_s": geo.r12_s.tolist(), "tool_channel": "TM1-TM2", **window}  # fmt: skip


def _slew(t: np.ndarray, t0: float, t1: float, peak: float) -> tuple[np.ndarray, np.ndarray]:
    d = t1 - t0
    if d <= 0:
        raise ValueError("rotation_coupling: the slew window must end after its onset")
    inside = (t >= t0) & (t <= t1)
    ph = np.pi * (t - t0) / d
    w = np.where(inside, peak * np.sin(ph) ** 2, 0.0)
    wd = np.where(inside, peak * np.pi / d * np.sin(2 * ph), 0.0)
    return w, wd


def _jitter(t: np.ndarray, peak: float, seed: int, axis: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x0A771, axis]))
    duration = t[-1] + (t[1] - t[0])
    f = np.geomspace(2.0 / duration, 0.05, 24)
    phase = rng.uniform(0, 2 * np.pi, f.size)
    arg = 2 * np.pi * f[:, None] * t[None, :] + phase[:, None]
    w = np.sin(arg).sum(axis=0)
    wd = (2 * np.pi * f[:, None] * np.cos(arg)).sum(axis=0)
    scale = peak / max(np.abs(w).max(), 1e-300)
    return w * scale, wd * scale


# --------------------------------------------------------------------------- sensing


class SensingCrossTalk(EffectModel):
    """A readout that also sees another axis: option ``sensor`` = ``disp`` (displacement
    readout, in the loop: ``x_meas,a = r_a + c r_b + N_m``) or ``acc`` (the accelerometer
    channel after the run: ``acc_a + c acc_b``, both as measured); option ``source``
    (default the other in-plane axis of the same test mass)."""

    name, parameter, unit, limit = "sensing_cross_talk", "c", "1", 0.1
    options = {"source": None, "sensor": "disp"}

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        src = PARTNER[ch] if opt["source"] is None else opt["source"]
        if src not in AXES or src == ch:
            raise ValueError(f"{self.name}: option 'source' must be one of "
                             f"{[a for a in AXES if a != ch]}; got {src!r}")  # fmt: skip
        a, s, c = AXES.index(ch), AXES.index(src), inj.magnitude
        if opt["sensor"] == "disp":
            b.const("readout", np.eye(4))[a, s] += c
        elif opt["sensor"] == "acc":
            b.post.append(lambda chans: _mix(chans, f"acc_{ch}", f"acc_{src}", c))
        else:
            raise ValueError(f"{self.name}: option 'sensor' must be 'disp' or 'acc'; "
                             f"got {opt['sensor']!r}")  # fmt: skip
        return {"c": c, "source": src, "sensor": opt["sensor"],
                "tool_channel": f"{opt['sensor']}:{ch}<-{src}"}  # fmt: skip


def _mix(chans: dict[str, np.ndarray], to: str, frm: str, c: float) -> None:
    # uses the channel as recorded, before this effect: one consistent order of post-steps
    chans[to] = chans[to] + c * chans[frm]


class ReadoutScale(EffectModel):
    """Readout calibration error ``(1 + e)``: option ``sensor`` = ``disp`` (displacement
    readout, in the loop: ``x_meas = (1 + e) r + N_m``; invisible in Eq. 10, where it is
    aliased with k) or ``acc`` (the accelerometer channel, ``(1 + e) acc`` as measured)."""

    name, parameter, unit, limit = "readout_scale", "e", "1", 0.1
    options = {"sensor": "disp"}

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        a, e = AXES.index(ch), inj.magnitude
        if opt["sensor"] == "disp":
            b.const("readout", np.eye(4))[a, a] += e
        elif opt["sensor"] == "acc":
            b.post.append(lambda chans: chans.__setitem__(f"acc_{ch}",
                                                          (1 + e) * chans[f"acc_{ch}"]))
        else:
            raise ValueError(f"{self.name}: option 'sensor' must be 'disp' or 'acc'; "
                             f"got {opt['sensor']!r}")  # fmt: skip
        return {"e": e, "sensor": opt["sensor"], "tool_channel": f"{opt['sensor']}:{ch}"}


class GeometryError(EffectModel):
    """True angles off the nominal written in the file: channel ``alpha`` turns arm 2
    (phi2 + d, so alpha + d), ``phi1``/``phi2`` turn one arm.  The simulator runs with
    the true geometry (f_B projections, K of its internal RLS); the attributes keep the
    nominal one.  A common rotation of both arms is unobservable (f_B is unknown)."""

    name, parameter, unit, limit = "geometry_error", "d_angle", "rad", 0.1
    channels = ("alpha", "phi1", "phi2")
    default_channel = "alpha"

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        g, d = b.geometry, inj.magnitude
        d1 = d if ch == "phi1" else 0.0
        d2 = d if ch in ("alpha", "phi2") else 0.0
        b.geometry = Geometry(g.phi1 + d1, g.phi2 + d2, g.separation)
        return {"d_phi1": d1, "d_phi2": d2, "d_alpha": d2 - d1,
                "true_phi1": b.geometry.phi1, "true_phi2": b.geometry.phi2,
                "true_alpha": b.geometry.alpha}  # fmt: skip


# --------------------------------------------------------------------------- transients


def _glitch_primitive(s: np.ndarray, beta: float, shape: str) -> np.ndarray:
    """Integral from 0 to s of the unit-area template (0 for s <= 0)."""
    u = np.maximum(s, 0.0) / beta
    if shape == "exp":
        return -np.expm1(-u)
    return 1.0 - (1.0 + u) * np.exp(-u)


def glitch_interval_average(t: np.ndarray, h: float, t0: float, beta: float,
                            shape: str) -> np.ndarray:  # fmt: skip
    """Average over ``[t_n, t_n + h)`` of the unit-area LPF glitch template starting at t0.

    Templates (Baghi et al., PRD 105, 042002 (2022)): ``exp`` = ``e^{-s/b}/b``,
    ``shapelet`` = ``s e^{-s/b}/b^2`` (s = t - t0 >= 0).  Averages of the exact
    antiderivative, so the velocity kick (impulse per unit mass) is exact.
    """
    return (_glitch_primitive(t + h - t0, beta, shape) - _glitch_primitive(t - t0, beta,
                                                                           shape)) / h  # fmt: skip


class Glitch(EffectModel):
    """Transient force on one axis (LISA Pathfinder-style glitch): velocity kick ``dv``
    [m s^-1] times a unit-area template (option ``shape`` = ``shapelet`` | ``exp``, decay
    time ``beta`` [s], default 5 s) starting at ``onset`` (default 0.4 T)."""

    name, parameter, unit, limit, windowed = "glitch", "dv", "m s^-1", 1e-6, True
    options = {"beta": 5.0, "shape": "shapelet"}

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        if inj.duration is not None:
            raise ValueError(f"{self.name}: use option 'beta' for the glitch's duration")
        beta = _option(self.name, "beta", opt["beta"], 1e-3, b.duration)
        if opt["shape"] not in ("shapelet", "exp"):
            raise ValueError(f"{self.name}: option 'shape' must be 'shapelet' or 'exp'; "
                             f"got {opt['shape']!r}")  # fmt: skip
        t0, _ = self.window(inj, b, onset=0.4 * b.duration)
        avg = glitch_interval_average(b.time, 1.0 / b.fs, t0, beta, opt["shape"])
        b.series("force", 4)[AXES.index(ch)] += inj.magnitude * avg
        return {"dv": inj.magnitude, "t0_s": t0, "decay_s": beta, "shape": opt["shape"]}


def coloured_noise(n: int, fs: float, asd_ref: float, exponent: float, f_ref: float,
                   rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """Gaussian noise with one-sided PSD ``S(f) = asd_ref^2 (f_ref / max(f, f_min))^p``.

    ``f_min = fs / n`` (flat below the lowest resolved frequency, so the variance is
    finite).  Frequency-domain synthesis: ``X_k = sqrt(S_k fs n / 2) (a + i b)/sqrt(2)``
    with a, b standard normal, then ``x = irfft(X)`` (numpy's 1/n convention), which gives
    ``sum_k S_k df`` as the variance; the DC bin is zero.
    """
    f = np.fft.rfftfreq(n, 1.0 / fs)
    f_min = fs / n
    psd = asd_ref**2 * (f_ref / np.maximum(f, f_min)) ** exponent
    spec = np.sqrt(psd * fs * n / 2) * (rng.standard_normal(f.size)
                                        + 1j * rng.standard_normal(f.size)) / math.sqrt(2)
    spec[0] = 0.0
    if n % 2 == 0:  # the Nyquist bin of a real series is real: keep its expected power
        spec[-1] = math.sqrt(psd[-1] * fs * n / 2) * rng.standard_normal()
    return np.fft.irfft(spec, n)


class ColoredNoise(EffectModel):
    """Extra acceleration noise on one axis with PSD ``A^2 (f_ref/f)^p`` (A = magnitude,
    the ASD at ``f_ref`` = 1 mHz; option ``exponent`` p, default 1 (1/f, "pink"); 2 is
    red), acting on the TM (in the dynamics and in the acceleration channel), optionally
    only in a window.  Its random numbers come from their own stream (seed, axis), so
    the Table 1 noise realisation is unchanged."""

    name, parameter, unit, limit = "colored_noise", "asd", "m s^-2 Hz^-1/2", 1e-8
    signed, windowed = False, True
    options = {"exponent": 1.0, "f_ref": 1e-3}

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        p = _option(self.name, "exponent", opt["exponent"], 0.0, 3.0)
        f_ref = _option(self.name, "f_ref", opt["f_ref"], 1e-6, b.fs / 2)
        a = AXES.index(ch)
        rng = np.random.default_rng(np.random.SeedSequence([b.seed, 0xC010, a]))
        noise = coloured_noise(b.n, b.fs, inj.magnitude, p, f_ref, rng)
        t0, t1 = self.window(inj, b)
        b.series("force", 4)[a] += noise * ((b.time >= t0) & (b.time < t1))
        return {"asd": inj.magnitude, "f_ref_hz": f_ref, "exponent": p, "onset_s": t0,
                "end_s": _finite(t1)}


EFFECTS: dict[str, EffectModel] = {e.name: e for e in (
    ActuationGain(), ActuationDelay(), StiffnessCrossCoupling(), CubicStiffness(),
    StiffnessDrift(), BiasDrift(), RotationCoupling(), SensingCrossTalk(), ReadoutScale(),
    GeometryError(), Glitch(), ColoredNoise(), ActuationQuantisation(),
)}  # fmt: skip
EFFECT_NAMES: tuple[str, ...] = tuple(EFFECTS)
