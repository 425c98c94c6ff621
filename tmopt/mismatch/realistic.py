"""Flight-like recordings: coloured noise everywhere, gaps, LPF glitches, varied runs, and
effects outside the catalogue (issue 26).

The round-one generator (:mod:`tmopt.mismatch.generate`) runs the paper's settings with
white Table 1 noise.  Real recordings (LISA Pathfinder) differ: the test-mass acceleration
noise rises at low frequency, the readout noise has a 1/f corner, telemetry drops samples,
glitches of the shapes catalogued from flight data (Baghi et al., PRD 105, 042002 (2022))
hit the test masses, and durations, rates and excitations vary.  This module draws such a
*scenario* at random and makes the recording, with two interchangeable backends:

* ``kernel`` -- the project's closed-loop simulator (:func:`tmopt.physics.simulator.simulate`)
  with the scenario's noise levels and the background as extra force series;
* ``foreign`` -- :mod:`tmopt.mismatch.foreign`, an independent simulation of the same
  equations (own integrator, controller, noise synthesis, accelerometer convention), so
  the diagnosis is not only tested on the code that shares its assumptions.

What a scenario holds (:func:`draw_scenario`; ranges from the issue):

* duration 1200-3600 s, sample rate 2-10 Hz, stiffness -2e-6..2e-6 s^-2 per axis, bias;
* excitation within Eq. 20: 1-3 tones per test mass (sum A w^2 <= alpha1 F_max and sum A
  <= alpha2 D), and (foreign backend only: the project's kernel has no y reference) tones
  on the non-sensitive axes;
* noise: every Table 1 level times a random factor in [0.5, 3]; extra test-mass
  acceleration noise of the LISA requirement's shape ``S_a(f) = S_w [1 + (f_lo/f)^2]
  [1 + (f/f_hi)^4]`` (LISA Science Requirements Document, ESA-L3-EST-SCI-RS-001 (2018);
  corners scaled to this band, see :class:`Background`); readout noise with a 1/f corner
  ``S_x = S_xw [1 + (f_c/f)^gamma]``;
* gaps: NaN runs and rows dropped from the file (a time jump), drawn with ``lisaglitch``'s
  gap generator (:class:`lisaglitch.GapMaskGenerator`);
* glitches: ``lisaglitch``'s LPF shapes (one- and two-sided double exponentials, n = 1
  shapelets), damping times 1-100 s, through the catalogue's ``glitch`` effect.

Out-of-catalogue effects (:data:`OUT_OF_CATALOGUE`): physics the tool does not model --
an unmodelled force line, a force step, an x*y product coupling, a slow bias modulation
at 1e-4 Hz, x|x| and u|u| nonlinearities, accelerometer clipping, a quadratic stiffness, a
readout time offset, a readout-noise burst, a stiffness step, a thermal relaxation.  A
truthful tool reports them as ``unexplained`` at the right channel, never as a catalogue
name.

Magnitudes are set by signal-to-noise ratio in the recording's own noise
(:func:`scale_to_snr`), because a fixed physical magnitude is invisible in one scenario
and overwhelming in the next.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from tmopt.mismatch.effects import Builder, Injection, effect
from tmopt.mismatch.effects.glitch import Glitch
from tmopt.mismatch.generate import (
    TRUTH_FORMAT,
    TRUTH_VERSION,
    GenerationError,
    _effect_truth,
    excess_snr,
    matched_snr,
    residual_families,
    whitened_power,
)
from tmopt.physics.control import PAPER_RATE
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import AXES, ROTATION_CHANNELS, Recording, validate
from tmopt.physics.scenario import Settings, excitation, simulation_config

__all__ = ["Background", "Scenario", "OOC", "OUT_OF_CATALOGUE", "draw_scenario",
           "realistic_recording", "signature_snr", "scale_to_snr", "SCALER_VERSION", "psd_noise",
           "BACKENDS"]  # fmt: skip

BACKENDS = ("kernel", "foreign")
#: Eq. 20's budgets: alpha1 F_max (peak acceleration) and alpha2 D (peak displacement).
F_MAX = 1e-7
ACC_BUDGET = 0.5 * F_MAX
DISP_BUDGET = 0.1 * 4e-3


# ----------------------------------------------------------------------------- scenario


@dataclass(frozen=True)
class Background:
    """Noise of one recording, relative to the scenario's Table 1 levels.

    ``factors``: multipliers of the per-sample sigmas ``m1, m2, acc, ele, fb`` (each drawn
    in [0.5, 3]).  Test-mass acceleration noise: the white actuation level ``S_w`` times
    ``[1 + (f_lo/f)^2][1 + (f/f_hi)^4] - 1`` is *added* as a force, so the total has the
    LISA requirement's shape.  Its 8 mHz corner is where LISA's readout noise, converted
    to acceleration, takes over; this loop models the readout separately (below), so
    ``f_hi`` is put at f_s/4..f_s/2, a blue tail of at most 17x in power at Nyquist instead
    of the 1e10x an 8 mHz corner would give at 5 Hz.  ``f_lo`` is drawn in 0.4-4 mHz
    (LPF's 1/f^2 rise sets in below ~1 mHz; scaled up so that it shows within 20-60 min).
    Readout: ``S_x = S_m [1 + (f_c/f)^gamma]`` on every displacement readout, f_c in
    1-30 mHz, gamma in [1, 2].
    """

    factors: dict[str, float]
    acc_f_lo: float
    acc_f_hi: float
    readout_f_c: float
    readout_gamma: float


@dataclass(frozen=True)
class Scenario:
    """Everything about one recording except the concealed effects and the noise seed.

    ``tones``: per axis (x1, x2, y1, y2) a list of (amplitude m, period s, phase rad);
    y tones need the foreign backend.  ``gaps``: (start s, stop s, kind) with kind
    ``nan`` (all channels NaN), ``nan_some`` (the readouts only) or ``drop`` (rows removed
    from the file).  ``glitches``: background glitches (catalogue ``glitch`` injections).
    ``acc_convention`` (foreign only): ``mean`` (the accelerometer reports the mean over
    [t_n, t_{n+1})), ``held`` (``k r(t_n)`` plus the force held over the step, as the
    kernel) or ``end`` (``k r(t_{n+1})`` plus that force; never drawn by
    :func:`draw_scenario`, whose sets stay as read); ``force_stamp`` (foreign only):
    ``applied`` (the force stamped n acts from t_n) or ``previous`` (it acted over
    [t_{n-1}, t_n)).  ``integrator`` (foreign only): ``rk4`` (the default), or a simulator
    that takes Euler steps with the acceleration at each step's start -- ``symplectic``
    (``v += h a; r += h v``) or ``explicit`` (``r += h v; v += h a``), ``substeps`` of
    them per sample, the first one's acceleration recorded; never drawn
    (docs/mismatch.md 9.26).  ``readout_sampling`` (foreign only): ``point`` (the position
    at t_n, the default) or ``mean`` (an integrating readout: the mean position over the
    step that ends at t_n, which the controller also sees; never drawn, 9.27).
    """

    duration: float = 1800.0
    sample_rate: float = PAPER_RATE
    stiffness: tuple[float, float, float, float] = (1e-7, 1e-7, 1e-7, 1e-7)
    bias: tuple[float, float, float, float] = (1e-10, 1e-10, 1e-10, 1e-10)
    tones: tuple[tuple[tuple[float, float, float], ...], ...] = ((), (), (), ())
    controller: str = "frbf_pid"
    background: Background | None = None
    gaps: tuple[tuple[float, float, str], ...] = ()
    glitches: tuple[Injection, ...] = ()
    reference: bool = True
    witnesses: bool = True
    acc_convention: str = "mean"
    force_stamp: str = "applied"
    integrator: str = "rk4"  # INTEGRATORS
    substeps: int = 1  # Euler steps per sample
    readout_sampling: str = "point"  # READOUT_SAMPLINGS

    @property
    def n(self) -> int:
        return int(round(self.duration * self.sample_rate))

    def excitation_spec(self) -> str:
        """The x tones as an ``excitation`` spec string (``none`` without tones)."""
        if not any(self.tones[:2]):
            return "none"
        parts = [",".join(f"{a!r}@{p!r}@{ph!r}" for a, p, ph in tm) or "0@1000"
                 for tm in self.tones[:2]]  # fmt: skip
        return "multisine:" + ";".join(parts)

    def settings(self) -> Settings:
        return Settings(duration=self.duration, sample_rate=self.sample_rate,
                        excitation=self.excitation_spec(), controller=self.controller,
                        stiffness=tuple(self.stiffness), bias=tuple(self.bias),
                        witnesses=self.witnesses)  # fmt: skip

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["glitches"] = [asdict(g) for g in self.glitches]
        d["excitation"] = self.excitation_spec()
        if self.integrator == "rk4":  # the read sets' truths (and names) as they were
            del d["integrator"]
        if self.substeps == 1:
            del d["substeps"]
        if self.readout_sampling == "point":
            del d["readout_sampling"]
        return d


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _draw_tones(rng: np.random.Generator, duration: float, fs: float,
                count: int) -> tuple[tuple[float, float, float], ...]:  # fmt: skip
    """``count`` tones within Eq. 20: periods log-uniform in [max(20 s, 10/fs), T/3],
    amplitudes sharing a random fraction (10-90 %) of both budgets."""
    if count == 0:
        return ()
    periods = np.array([_log_uniform(rng, max(20.0, 10.0 / fs), duration / 3)
                        for _ in range(count)])  # fmt: skip
    weights = rng.dirichlet(np.ones(count))
    w2 = (2 * np.pi / periods) ** 2
    # amplitudes a_i = s * weights_i / w2_i use s of the acceleration budget ...
    s_acc = ACC_BUDGET / float(np.sum(weights))
    amps = s_acc * weights / w2
    # ... and are cut to the displacement budget (Eq. 17 with x(0) = 0 reaches 2 sum A)
    amps *= min(1.0, DISP_BUDGET / (2.0 * float(np.sum(amps))))
    amps *= rng.uniform(0.1, 0.9)
    phases = rng.uniform(0, 2 * np.pi, count)
    return tuple((float(a), float(p), float(ph)) for a, p, ph in zip(amps, periods, phases))


def draw_scenario(seed: int, backend: str = "kernel", **fixed: Any) -> Scenario:
    """A random flight-like scenario (deterministic in ``seed``); ``fixed`` overrides any
    field (e.g. ``gaps=()`` or ``duration=1200.0``).  ``backend`` decides whether y tones
    may be drawn (foreign only)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}; got {backend!r}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5CE7A]))
    duration = float(np.round(rng.uniform(1200.0, 3600.0), 1))
    fs = float(rng.choice([2.0, 2.5, 4.0, 5.0, 8.0, 10.0]))
    tones = [_draw_tones(rng, duration, fs, int(rng.integers(1, 4))) for _ in range(2)]
    y_exc = backend == "foreign" and rng.random() < 0.5
    tones += [_draw_tones(rng, duration, fs, int(rng.integers(1, 3))) if y_exc else ()
              for _ in range(2)]  # fmt: skip
    bg = Background(
        factors={k: _log_uniform(rng, 0.5, 3.0) for k in ("m1", "m2", "acc", "ele", "fb")},
        acc_f_lo=_log_uniform(rng, 4e-4, 4e-3), acc_f_hi=rng.uniform(0.25, 0.5) * fs,
        readout_f_c=_log_uniform(rng, 1e-3, 3e-2), readout_gamma=float(rng.uniform(1.0, 2.0)),
    )  # fmt: skip
    sc = Scenario(
        duration=duration, sample_rate=fs,
        stiffness=tuple(float(v) for v in rng.uniform(-2e-6, 2e-6, 4)),
        bias=tuple(float(v) for v in rng.uniform(-3e-10, 3e-10, 4)),
        tones=tuple(tones), controller=str(rng.choice(["frbf_pid", "pid"])), background=bg,
        gaps=_draw_gaps(rng, duration, fs), glitches=(),
        reference=bool(rng.random() < 0.5), witnesses=bool(rng.random() < 0.8),
        acc_convention=str(rng.choice(["mean", "held"])),
        force_stamp=str(rng.choice(["applied", "previous"])),
    )  # fmt: skip
    return replace(sc, **fixed) if fixed else sc


def _draw_gaps(rng: np.random.Generator, duration: float, fs: float):
    """0-4 gaps, 1-60 s each, from ``lisaglitch``'s gap generator (unplanned gaps: an
    exponential waiting time); each is a NaN run, a NaN run of the readouts only, or rows
    dropped from the file."""
    from lisaglitch import GapMaskGenerator

    n_gaps = int(rng.integers(0, 5))
    if n_gaps == 0:
        return ()
    year = 365.25 * 86400.0
    length = _log_uniform(rng, 1.0, 60.0)
    t = np.arange(int(round(duration * fs))) / fs
    defs = {"planned": {}, "unplanned": {"telemetry": {
        "rate_per_year": n_gaps / duration * year, "duration_hr": length / 3600.0}}}
    seed = int(rng.integers(1, 2**31 - 1))
    state = np.random.get_state()  # the gap generator seeds numpy's global stream
    try:
        mask = GapMaskGenerator(t, defs, treat_as_nan=True, planseed=seed,
                                unplanseed=seed).generate_mask()  # fmt: skip
    finally:
        np.random.set_state(state)
    bad = np.isnan(mask)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2]):
        kind = str(rng.choice(["nan", "nan_some", "drop"]))
        out.append((float(a / fs), float(b / fs), kind))
    return tuple(out)


def draw_glitches(seed: int, scenario: Scenario, count: int,
                  dv_range: tuple[float, float] = (1e-11, 1e-9),
                  ) -> tuple[Injection, ...]:  # fmt: skip
    """``count`` background glitches of LPF shapes (Baghi et al. 2022) at random times and
    axes: damping times 1-100 s, kick dv log-uniform in ``dv_range`` [m/s], random sign."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x611C4]))
    out = []
    for _ in range(count):
        shape = str(rng.choice(["shapelet", "one_sided", "two_sided"]))
        beta = _log_uniform(rng, 1.0, 100.0)
        opts: dict[str, Any] = {"shape": shape, "beta": beta}
        if shape != "shapelet":
            opts["t_rise"] = beta * rng.uniform(0.05, 0.5)
        if shape == "two_sided":
            opts["overshoot"] = rng.uniform(1.5, 4.0)
        onset = float(rng.uniform(0.05, 0.85) * scenario.duration)
        dv = _log_uniform(rng, *dv_range) * rng.choice([-1.0, 1.0])
        out.append(Injection(Glitch.name, float(dv), str(rng.choice(AXES)), onset=onset,
                             options=opts))  # fmt: skip
    return tuple(out)


# ------------------------------------------------------------------- noise synthesis


def psd_noise(n: int, fs: float, psd: Callable[[np.ndarray], np.ndarray],
              rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """Gaussian noise with one-sided PSD ``psd(f)`` [unit^2/Hz] (frequency-domain synthesis,
    as :func:`tmopt.mismatch.effects.colored_noise.coloured_noise`; the DC bin is zero and
    f below the first bin is held at the first bin's value)."""
    f = np.fft.rfftfreq(n, 1.0 / fs)
    s = psd(np.maximum(f, fs / n))
    spec = np.sqrt(s * fs * n / 2) * (rng.standard_normal(f.size)
                                      + 1j * rng.standard_normal(f.size)) / math.sqrt(2)
    spec[0] = 0.0
    if n % 2 == 0:
        spec[-1] = math.sqrt(s[-1] * fs * n / 2) * rng.standard_normal()
    return np.fft.irfft(spec, n)


def acc_shape(bg: Background) -> Callable[[np.ndarray], np.ndarray]:
    """``[1 + (f_lo/f)^2][1 + (f/f_hi)^4] - 1``: the coloured excess over the white floor."""
    return lambda f: (1 + (bg.acc_f_lo / f) ** 2) * (1 + (f / bg.acc_f_hi) ** 4) - 1.0


def readout_shape(bg: Background) -> Callable[[np.ndarray], np.ndarray]:
    """``(f_c/f)^gamma``: the 1/f excess of the readout over its white floor."""
    return lambda f: (bg.readout_f_c / f) ** bg.readout_gamma


# ------------------------------------------------------------- out-of-catalogue effects


@dataclass
class OOC:
    """One out-of-catalogue effect: physics the diagnosis does not model.

    ``force(t, r, v, u)`` -> extra acceleration (4, ...) from time, true position and
    velocity, and the applied command (arrays (4, ...) sampled together; ``state`` says
    whether it reads r, v or u); ``post(chans, truth_state)`` transforms recorded channels.
    ``channel``: where a truthful tool should locate it (an axis, or ``<axis> readout`` for
    the kinematic check).
    """

    name: str
    magnitude: float
    axis: str
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def spec(self) -> OOCKind:
        return OUT_OF_CATALOGUE[self.name]

    @property
    def channel(self) -> str:
        return self.spec.channel.format(a=self.axis)

    def truth(self) -> dict[str, Any]:
        return {"name": self.name, "catalogue": False, "magnitude": self.magnitude,
                "unit": self.spec.unit, "axis": self.axis, "tool_channel": self.channel,
                "parameters": dict(self.params), "description": self.spec.description}  # fmt: skip


@dataclass(frozen=True)
class OOCKind:
    description: str
    unit: str
    channel: str  # format with a=axis
    trial: float  # a magnitude to start the SNR scaling from
    state: bool = False  # reads the state or command (two-pass on the kernel backend)
    noise_like: bool = False  # SNR grows with magnitude^2
    draw: Callable[[np.random.Generator, Scenario], dict[str, Any]] = lambda rng, sc: {}
    force: Callable[..., np.ndarray] | None = None
    post: Callable[..., None] | None = None


def _axis_row(axis: str, values: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    out = np.zeros(shape)
    out[AXES.index(axis)] = values
    return out


def _f_line(o: OOC, t, r, v, u):
    p = o.params
    return _axis_row(o.axis, o.magnitude * np.sin(2 * np.pi * p["f_hz"] * t + p["phase"]),
                     (4,) + np.shape(t))  # fmt: skip


def _f_step(o: OOC, t, r, v, u):
    return _axis_row(o.axis, o.magnitude * (t >= o.params["t_step"]), (4,) + np.shape(t))


def _f_modulation(o: OOC, t, r, v, u):
    p = o.params
    return _axis_row(o.axis, o.magnitude * np.sin(2 * np.pi * 1e-4 * t + p["phase"]),
                     (4,) + np.shape(t))  # fmt: skip


def _f_relax(o: OOC, t, r, v, u):
    p = o.params
    s = np.maximum(t - p["t0"], 0.0)
    return _axis_row(o.axis, o.magnitude * -np.expm1(-s / p["tau"]), (4,) + np.shape(t))


def _f_xy(o: OOC, t, r, v, u):
    a = AXES.index(o.axis)
    return _axis_row(o.axis, o.magnitude * r[a] * r[a + 2], (4,) + np.shape(r[0]))


def _f_xabs(o: OOC, t, r, v, u):
    a = AXES.index(o.axis)
    return _axis_row(o.axis, o.magnitude * r[a] * np.abs(r[a]), (4,) + np.shape(r[0]))


def _f_uabs(o: OOC, t, r, v, u):
    a = AXES.index(o.axis)
    return _axis_row(o.axis, o.magnitude * u[a] * np.abs(u[a]), (4,) + np.shape(u[0]))


def _f_quad(o: OOC, t, r, v, u):
    a = AXES.index(o.axis)
    return _axis_row(o.axis, o.magnitude * r[a] ** 2, (4,) + np.shape(r[0]))


def _f_kstep(o: OOC, t, r, v, u):
    a = AXES.index(o.axis)
    return _axis_row(o.axis, o.magnitude * (t >= o.params["t_step"]) * r[a],
                     (4,) + np.shape(r[0]))  # fmt: skip


def _p_clip(o: OOC, chans: dict[str, np.ndarray], state: dict[str, np.ndarray]) -> None:
    name = f"acc_{o.axis}"
    level = float(np.quantile(np.abs(chans[name]), o.params["quantile"]))
    o.params["level"] = level
    chans[name] = np.clip(chans[name], -level, level)


def _p_timing(o: OOC, chans: dict[str, np.ndarray], state: dict[str, np.ndarray]) -> None:
    """The readout of the axis is stamped ``tau`` late: ``x(t_n - tau)`` replaces
    ``x(t_n)`` (true motion interpolated, the readout noise kept)."""
    a = AXES.index(o.axis)
    t, r = state["time"], state["r"][a]
    chans[o.axis] = chans[o.axis] + np.interp(t - o.magnitude, t, r) - r


def _p_burst(o: OOC, chans: dict[str, np.ndarray], state: dict[str, np.ndarray]) -> None:
    """Readout noise of the axis raised to ``magnitude`` x its white level in a window."""
    p = o.params
    t = chans["time"]
    inside = (t >= p["t0"]) & (t < p["t0"] + p["length"])
    rng = np.random.default_rng(np.random.SeedSequence([int(p["seed"]), 0xB0057]))
    extra = rng.standard_normal(t.size) * p["sigma"] * o.magnitude
    chans[o.axis] = chans[o.axis] + np.where(inside, extra, 0.0)


def _draw_line(rng, sc: Scenario):
    # a frequency away from every excitation tone and its first harmonics
    tones = [1 / p for tm in sc.tones for _, p, _ in tm]
    lines = [k * f for f in tones for k in (1, 2, 3)]
    for _ in range(100):
        f = _log_uniform(rng, 10.0 / sc.duration, 0.3 * sc.sample_rate)
        if all(abs(f - g) > 5.0 / sc.duration for g in lines):
            break
    return {"f_hz": f, "phase": float(rng.uniform(0, 2 * np.pi))}


def _draw_time(key: str, lo: float = 0.2, hi: float = 0.8):
    return lambda rng, sc: {key: float(rng.uniform(lo, hi) * sc.duration)}


#: The out-of-catalogue effects of the realistic benchmark (each reported "unexplained").
OUT_OF_CATALOGUE: dict[str, OOCKind] = {
    "unmodelled_line": OOCKind("a force line at a frequency unrelated to the excitation",
                               "m s^-2", "{a}", 1e-12, draw=_draw_line, force=_f_line),
    "force_step": OOCKind("a lasting step of the force on one axis", "m s^-2", "{a}", 1e-12,
                          draw=_draw_time("t_step"), force=_f_step),
    "xy_product": OOCKind("an x*y product coupling (force c x y on the x axis): lines at "
                          "f_x +- f_y", "m^-1 s^-2", "{a}", 1e2, state=True, force=_f_xy),
    "bias_modulation": OOCKind("a slow bias modulation at 1e-4 Hz (a curved, not linear, "
                               "bias change)", "m s^-2", "{a}", 1e-12,
                               draw=lambda rng, sc: {"phase": float(rng.uniform(0, 2 * np.pi))},
                               force=_f_modulation),
    "position_abs": OOCKind("a nonlinear force kappa x|x| (even-power stiffness with a sign)",
                            "m^-1 s^-2", "{a}", 1e-3, state=True, force=_f_xabs),
    "actuation_abs": OOCKind("a nonlinear actuation term beta u|u| of the applied force",
                             "s^2 m^-1", "{a}", 1e2, state=True, force=_f_uabs),
    "quadratic_stiffness": OOCKind("a quadratic stiffness k2 x^2 (the catalogue has the "
                                   "cubic only)", "m^-1 s^-2", "{a}", 1e-3, state=True,
                                   force=_f_quad),
    "stiffness_step": OOCKind("a sudden stiffness change (not a linear drift)", "s^-2", "{a}",
                              1e-8, state=True, draw=_draw_time("t_step"), force=_f_kstep),
    "thermal_relaxation": OOCKind("a force relaxing exponentially to a new level (tau "
                                  "100-600 s)", "m s^-2", "{a}", 1e-12,
                                  draw=lambda rng, sc: {"t0": float(rng.uniform(0.2, 0.6)
                                                                    * sc.duration),
                                                        "tau": _log_uniform(rng, 100, 600)},
                                  force=_f_relax),  # fmt: skip
    "acc_clipping": OOCKind("the accelerometer channel clips (ADC saturation) at a level "
                            "below its peaks", "1 (quantile)", "{a}", 0.9,
                            draw=lambda rng, sc: {}, post=_p_clip),
    "readout_timing": OOCKind("the displacement readout is stamped tau late (a sub-sample "
                              "timing offset)", "s", "{a} readout", 0.02, post=_p_timing),
    "readout_burst": OOCKind("the readout noise rises for 100-300 s (a noisy episode)", "1",
                             "{a} readout", 10.0, noise_like=True,
                             draw=lambda rng, sc: {"t0": float(rng.uniform(0.1, 0.6)
                                                               * sc.duration),
                                                   "length": float(rng.uniform(100, 300)),
                                                   "seed": int(rng.integers(2**31))},
                             post=_p_burst),  # fmt: skip
}


def make_ooc(name: str, magnitude: float, axis: str, seed: int, sc: Scenario) -> OOC:
    """An out-of-catalogue effect with its random parameters drawn for ``sc``."""
    if name not in OUT_OF_CATALOGUE:
        raise ValueError(f"unknown out-of-catalogue effect {name!r}; choose from "
                         f"{sorted(OUT_OF_CATALOGUE)}")  # fmt: skip
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x00C, len(name)]))
    kind = OUT_OF_CATALOGUE[name]
    params = dict(kind.draw(rng, sc))
    if name == "acc_clipping":
        params["quantile"] = float(magnitude)
    return OOC(name, float(magnitude), axis, params)


# ---------------------------------------------------------------------- the recording


@dataclass
class Plan:
    """What a backend simulates: scenario, noise seed, the catalogue hooks (a
    :class:`Builder`), the out-of-catalogue effects and the references (4, N)."""

    scenario: Scenario
    seed: int
    builder: Builder
    ooc: list[OOC]
    refs: np.ndarray
    cfg_sigmas: dict[str, float]


def _plan(sc: Scenario, effects: Sequence[Injection], ooc: Sequence[OOC], seed: int) -> Plan:
    builder = Builder(sc.n, sc.sample_rate, Geometry(), int(seed))
    truths = []
    for inj in tuple(effects) + tuple(sc.glitches):
        truths.append(_effect_truth(inj, effect(inj.name).inject(inj, builder)))
    builder.truths = truths  # type: ignore[attr-defined]
    refs = np.zeros((4, sc.n))
    ref1, ref2, _ = excitation(sc.excitation_spec(), sc.duration, sc.sample_rate)
    refs[0], refs[1] = ref1, ref2
    t = builder.time
    for k in (2, 3):
        for a, p, ph in sc.tones[k]:
            refs[k] += a * (np.sin(2 * np.pi * t / p + ph) - math.sin(ph))
    cfg = simulation_config(sc.settings(), builder.geometry)
    sig = {"m1": cfg.sigma_m1, "m2": cfg.sigma_m2, "acc": cfg.sigma_acc, "ele": cfg.sigma_ele,
           "fb": cfg.fb_sigma}  # fmt: skip
    if sc.background is not None:
        sig = {k: v * sc.background.factors[k] for k, v in sig.items()}
    return Plan(sc, int(seed), builder, list(ooc), refs, sig)


def _background_force(plan: Plan) -> np.ndarray:
    """The coloured excess of the TM acceleration noise (4, N), its own random stream."""
    sc, bg = plan.scenario, plan.scenario.background
    out = np.zeros((4, sc.n))
    if bg is None:
        return out
    s_w = 2 * plan.cfg_sigmas["ele"] ** 2 / sc.sample_rate  # one-sided PSD of N_ele
    shape = acc_shape(bg)
    for a in range(4):
        rng = np.random.default_rng(np.random.SeedSequence([plan.seed, 0xACC, a]))
        out[a] = psd_noise(sc.n, sc.sample_rate, lambda f: s_w * shape(f), rng)
    return out


def _readout_colour(plan: Plan) -> np.ndarray:
    """The 1/f excess of the readout noise (4, N), its own random stream."""
    sc, bg = plan.scenario, plan.scenario.background
    out = np.zeros((4, sc.n))
    if bg is None:
        return out
    shape = readout_shape(bg)
    for a in range(4):
        sigma = plan.cfg_sigmas["m1" if a < 2 else "m2"]
        s_w = 2 * sigma**2 / sc.sample_rate
        rng = np.random.default_rng(np.random.SeedSequence([plan.seed, 0x4EAD, a]))
        out[a] = psd_noise(sc.n, sc.sample_rate, lambda f, s=s_w: s * shape(f), rng)
    return out


def _run_kernel(plan: Plan) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Kernel backend: the project's simulator.  Time-only out-of-catalogue forces are
    sampled at mid-step; state- or command-dependent ones are evaluated on a first pass's
    true motion and commands and applied in a second pass (first order in the effect, like
    the kernel's own ZOH of perturbations)."""
    from tmopt.physics.recording import recording_from_simulation
    from tmopt.physics.simulator import simulate

    sc, b = plan.scenario, plan.builder
    cfg = simulation_config(sc.settings(), b.geometry)
    cfg = replace(cfg, sigma_m1=plan.cfg_sigmas["m1"], sigma_m2=plan.cfg_sigmas["m2"],
                  sigma_acc=plan.cfg_sigmas["acc"], sigma_ele=plan.cfg_sigmas["ele"],
                  fb_sigma=plan.cfg_sigmas["fb"])  # fmt: skip
    force = b.series("force", 4)
    force += _background_force(plan)
    t_mid = b.time + 0.5 / sc.sample_rate
    zeros = np.zeros((4, sc.n))
    for o in plan.ooc:
        if o.spec.force is not None and not o.spec.state:
            force += o.spec.force(o, t_mid, zeros, zeros, zeros)
    ref1, ref2 = plan.refs[0][None], plan.refs[1][None]

    def run():
        res = simulate(ref1, ref2, cfg, plan.seed, b.perturbations())
        if res.diverged[0]:
            raise GenerationError(f"the closed loop diverged ({res.reason[0]})")
        return res

    res = run()
    stateful = [o for o in plan.ooc if o.spec.force is not None and o.spec.state]
    if stateful:
        d = res.design(0)
        r = np.array([d[f"{a}_true"] for a in AXES])
        v = np.gradient(r, 1.0 / sc.sample_rate, axis=1)
        u = np.array([d[f"force_{a}"] for a in AXES])
        for o in stateful:
            force += o.spec.force(o, b.time, r, v, u)
        res = run()
    rec = recording_from_simulation(res, 0, geometry=Geometry())
    chans = {k: np.array(v) for k, v in rec.channels.items()}
    d = res.design(0)
    state = {"time": b.time.copy(), "r": np.array([d[f"{a}_true"] for a in AXES])}
    return chans, state


def _run(plan: Plan, backend: str):
    if backend == "kernel":
        return _run_kernel(plan)
    from tmopt.mismatch.foreign import run_foreign

    return run_foreign(plan)


def _finish(plan: Plan, chans: dict[str, np.ndarray], state: dict[str, np.ndarray],
            backend: str, gaps: bool) -> Recording:  # fmt: skip
    sc = plan.scenario
    for step in plan.builder.post:  # catalogue sensor effects
        step(chans)
    if backend == "kernel":  # the foreign backend has its readout colour in the loop
        col = _readout_colour(plan)
        for a, name in enumerate(AXES):
            chans[name] = chans[name] + col[a]
    for o in plan.ooc:
        if o.spec.post is not None:
            # the axis's white readout sigma [m] (a readout burst is a multiple of it)
            o.params.setdefault("sigma", plan.cfg_sigmas["m1" if o.axis in AXES[:2] else "m2"])
            o.spec.post(o, chans, state)
    if not sc.reference:
        chans.pop("ref_x1", None)
        chans.pop("ref_x2", None)
    if sc.witnesses and ROTATION_CHANNELS[0] not in chans:
        chans.update({c: np.zeros(sc.n) for c in ROTATION_CHANNELS})
    if not sc.witnesses and ROTATION_CHANNELS[0] in chans and not any(
            np.any(chans[c]) for c in ROTATION_CHANNELS):  # fmt: skip
        for c in ROTATION_CHANNELS:
            chans.pop(c)
    if gaps:
        chans = _apply_gaps(chans, sc)
    attrs = {"format": "tmopt-recording", "format_version": 1,
             "sample_rate": float(sc.sample_rate), "alpha": Geometry().alpha,
             "phi1": Geometry().phi1, "phi2": Geometry().phi2}  # fmt: skip
    return validate(Recording(chans, attrs, source="<realistic>"))


def _apply_gaps(chans: dict[str, np.ndarray], sc: Scenario) -> dict[str, np.ndarray]:
    t = chans["time"]
    drop = np.zeros(t.size, bool)
    out = {k: v.copy() for k, v in chans.items()}
    for t0, t1, kind in sc.gaps:
        sel = (t >= t0) & (t < t1)
        if kind == "drop":
            drop |= sel
            continue
        names = [c for c in out if c != "time"]
        if kind == "nan_some":
            names = list(AXES)
        for c in names:
            out[c][sel] = np.nan
    if drop.any():
        keep = ~drop
        keep[0] = keep[-1] = True  # a file starts and ends with a stored row
        out = {k: v[keep] for k, v in out.items()}
    return out


def realistic_recording(scenario: Scenario, effects: Sequence[Injection] = (),
                        ooc: Sequence[OOC] = (), seed: int = 0, backend: str = "kernel",
                        gaps: bool = True) -> tuple[Recording, dict[str, Any]]:  # fmt: skip
    """Simulate one flight-like recording -> (recording, truth dict).

    ``effects``: catalogue :class:`Injection` s; ``ooc``: out-of-catalogue effects
    (:func:`make_ooc`); background glitches come from ``scenario.glitches`` and are listed
    in the truth like any catalogue effect (``"background": true``).  ``gaps=False`` skips
    the scenario's gaps (used for the SNR of a signature).
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}; got {backend!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer in [0, inf); got {seed!r}")
    _check_integrator(scenario, backend)
    plan = _plan(scenario, effects, ooc, int(seed))
    chans, state = _run(plan, backend)
    rec = _finish(plan, chans, state, backend, gaps)
    truths = plan.builder.truths  # type: ignore[attr-defined]
    for tr in truths[len(effects):]:
        tr["background"] = True
    truth = {
        "format": TRUTH_FORMAT, "format_version": TRUTH_VERSION, "generator": "realistic",
        "backend": backend, "seed": int(seed), "clean": not effects and not ooc,
        "effects": truths, "out_of_catalogue": [o.truth() for o in ooc],
        "scenario": scenario.as_dict(), "noise_sigmas": plan.cfg_sigmas,
        "settings": {"stiffness": list(scenario.stiffness)},
        "samples": {"grid": scenario.n, "valid": int(np.sum(rec.valid))},
    }  # fmt: skip
    return rec, truth


#: ``Scenario.integrator``: the foreign simulator's RK4, or Euler steps.
INTEGRATORS = ("rk4", "symplectic", "explicit")
#: ``Scenario.readout_sampling``: the position at the sample, or its mean over the step.
READOUT_SAMPLINGS = ("point", "mean")


def _check_integrator(scenario: Scenario, backend: str) -> None:
    if scenario.acc_convention not in ("held", "mean", "end"):
        raise ValueError("acc_convention must be one of ('held', 'mean', 'end'); got "
                         f"{scenario.acc_convention!r}")
    if scenario.integrator not in INTEGRATORS:
        raise ValueError(f"integrator must be one of {INTEGRATORS}; got {scenario.integrator!r}")
    if scenario.readout_sampling not in READOUT_SAMPLINGS:
        raise ValueError(f"readout_sampling must be one of {READOUT_SAMPLINGS}; got "
                         f"{scenario.readout_sampling!r}")
    if scenario.readout_sampling != "point" and backend != "foreign":
        raise ValueError(f"readout_sampling={scenario.readout_sampling!r} needs backend "
                         f"'foreign'; got backend {backend!r}")
    if isinstance(scenario.substeps, bool) or not isinstance(scenario.substeps, int) \
            or not 1 <= scenario.substeps <= 100:  # fmt: skip
        raise ValueError(f"substeps must be an integer in [1, 100]; got {scenario.substeps!r}")
    if scenario.substeps > 1 and scenario.integrator == "rk4":
        raise ValueError(f"substeps={scenario.substeps} goes with an Euler integrator "
                         f"{INTEGRATORS[1:]}; got integrator 'rk4'")
    if scenario.integrator != "rk4" and backend != "foreign":
        raise ValueError(f"integrator={scenario.integrator!r} needs backend 'foreign' (the "
                         f"kernel steps exactly); got backend {backend!r}")
    if scenario.integrator != "rk4" and scenario.acc_convention != "held":
        raise ValueError(f"integrator={scenario.integrator!r} records the acceleration its "
                         f"step used: acc_convention must be 'held'; got "
                         f"{scenario.acc_convention!r}")


def recording_name(truth: dict[str, Any]) -> str:
    key = json.dumps([truth["backend"], truth["seed"], truth["scenario"], truth["effects"],
                      truth["out_of_catalogue"]], sort_keys=True, default=str)  # fmt: skip
    return "rrec-" + hashlib.sha256(key.encode()).hexdigest()[:12]


# ----------------------------------------------------------------------------- SNR


#: Version of the SNR scaler.  1: the residual families of the raw channels.  2 (from stop
#: 39): the force channels first paired with the acceleration they act on, by the tool's
#: own criterion (:func:`tmopt.mismatch.fit.force_lag`).  Under version 1 a foreign
#: recording stamped ``previous`` had the misaligned force's step-to-step change in its
#: noise reference, so its effects were scaled far above their nominal SNR (docs/mismatch.md
#: section 10: 56 of 71 such items above twice it).  Kernel recordings (stamped
#: ``applied``) are the same under both.  The benchmark sets read before stop 39 were made
#: with version 1 (``--scaler-version 1`` remakes them).
SCALER_VERSIONS = (1, 2)
SCALER_VERSION = 2


def _families(rec: Recording, force_lag: int = 0) -> dict[str, np.ndarray]:
    return residual_families(rec, force_lag)


def signature_snr(scenario: Scenario, effects: Sequence[Injection] = (),
                  ooc: Sequence[OOC] = (), seed: int = 0, backend: str = "kernel",
                  noise_like: bool = False, clean: dict | None = None) -> float:  # fmt: skip
    """Optimal SNR of the effects' signature in this scenario's noise.

    As :func:`tmopt.mismatch.generate.detectability`: the residual families (f_B-free
    equation residual, per-axis kinematic residual) of the recording minus those of the
    clean recording with the same seed, against the noise PSD of the difference of two
    clean recordings (seeds ``seed``, ``seed + 7919``); matched filter, or the excess-power
    statistic for noise-like effects.  Gaps are left out (the signature of the full run).
    Every family has its force channels paired by the clean recording's force lag
    (``clean["force_lag"]``; 0 under scaler version 1, :data:`SCALER_VERSION`).
    ``clean`` caches the clean families, PSDs and lag between calls.
    """
    clean = _clean_cache(scenario, seed, backend) if clean is None else clean
    rec, _ = realistic_recording(scenario, effects, ooc, seed, backend, gaps=False)
    fam = _families(rec, clean.get("force_lag", 0))
    stat = excess_snr if noise_like else matched_snr
    vals = []
    for k in fam:
        w = whitened_power(fam[k] - clean["fam"][k], clean["psd"][k], scenario.sample_rate)
        vals.append(stat(w))
    return float(max(vals))


def _clean_cache(scenario: Scenario, seed: int, backend: str,
                 version: int = SCALER_VERSION) -> dict:  # fmt: skip
    """Clean families, noise PSDs and the force lag (version 2) shared by the scaler's calls."""
    from tmopt.mismatch.fit import data_from_recording, force_lag
    from tmopt.mismatch.generate import _psd_on_grid

    if version not in SCALER_VERSIONS:
        raise ValueError(f"version must be one of {SCALER_VERSIONS}; got {version!r}")
    rec_a = realistic_recording(scenario, (), (), seed, backend, gaps=False)[0]
    lag = force_lag(data_from_recording(rec_a))[0] if version >= 2 else 0
    a = _families(rec_a, lag)
    b = _families(realistic_recording(scenario, (), (), seed + 7919, backend, gaps=False)[0],
                  lag)  # fmt: skip
    psd = {k: _psd_on_grid((a[k] - b[k]) / math.sqrt(2), scenario.sample_rate) for k in a}
    return {"fam": a, "psd": psd, "force_lag": lag}


def scale_to_snr(scenario: Scenario, item: Injection | OOC, target: float, seed: int,
                 backend: str = "kernel", clean: dict | None = None,
                 limit: float | None = None) -> tuple[Injection | OOC, float]:  # fmt: skip
    """``item`` with its magnitude scaled so that its signature has SNR ~ ``target`` in this
    scenario (SNR linear in the magnitude, quadratic for noise-like effects; one trial and
    one correction).  Returns (scaled item, SNR reached)."""
    clean = _clean_cache(scenario, seed, backend) if clean is None else clean
    if isinstance(item, Injection):
        model = effect(item.name)
        noise_like, cap = model.noise_like, model.limit if limit is None else limit
    else:
        noise_like, cap = item.spec.noise_like, math.inf if limit is None else limit
    power = 2.0 if noise_like else 1.0
    cur = item
    rho = 0.0
    for _ in range(3):
        rho = _snr_of(scenario, cur, seed, backend, noise_like, clean)
        if rho <= 0 or not math.isfinite(rho):
            break
        if abs(rho / target - 1) < 0.15:
            break
        mag = cur.magnitude * (target / rho) ** (1 / power)
        mag = math.copysign(min(abs(mag), cap), mag)
        cur = replace(cur, magnitude=float(mag))
        if abs(mag) >= cap:
            rho = _snr_of(scenario, cur, seed, backend, noise_like, clean)
            break
    return cur, rho


def _snr_of(sc, item, seed, backend, noise_like, clean) -> float:
    try:
        if isinstance(item, Injection):
            return signature_snr(sc, [item], (), seed, backend, noise_like, clean)
        return signature_snr(sc, (), [item], seed, backend, noise_like, clean)
    except GenerationError:
        return math.inf
