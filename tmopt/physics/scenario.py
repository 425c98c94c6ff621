"""Scenarios of the closed loop: run settings, excitation specs and the one sample-rate rule.

What a run *is*, independent of who asks for it: the stiffness problem
(:mod:`tmopt.problems.stiffness`), the recording generator (:mod:`tmopt.mismatch.generate`)
and ``python -m tmopt.simulate`` all build their :class:`SimulationConfig` here, so one
setting means one physics on every route.

* :func:`config_at_rate` -- the sample-rate rule: :class:`SimulationConfig`'s defaults are
  the paper's 10 Hz design (Table 1 per-sample noise sigmas, Sec. 4.2 per-sample PID gains);
  at another rate the sigmas scale with ``sqrt(fs / 10 Hz)`` (same noise ASDs) and the
  incremental-PID gains are rescaled to the same continuous gains
  (:func:`tmopt.physics.control.rate_scaled_gains`; docs/decisions.md).  It also applies
  the named non-sensitive-axis settings of :data:`Y_AXES`.
* :class:`Settings` and :func:`simulation_config` -- a whole run (duration, rate,
  excitation spec, noise scale, controller, stiffness and bias truths, and the physics
  options ``ramp_in``, ``rls_columns``, ``y_axes``, ``jacobian``).
* :func:`excitation` -- the reference motions named by a spec string (``paper``,
  ``multisine:...``, ``chirp:...``, ``steps:...``, ``none``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tmopt.physics.control import PAPER_RATE, ControllerSettings, rate_scaled_gains
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import AXES
from tmopt.physics.simulator import SimulationConfig

__all__ = ["PAPER_RATE", "MIN_SAMPLE_RATE", "Y_AXES", "Y_GAP", "Settings", "config_at_rate",
           "simulation_config", "excitation", "excitation_axes"]  # fmt: skip

#: Lowest sample rate of the rule [Hz]: the 10 Hz design's loops, rescaled, are stable
#: from here to 1 kHz; below, the sample delay u_n -> x_{n+1} destabilises them (poles of
#: closed_loop_poles: the sensitive-axis PID below 0.948 Hz, the drag-free y loop below
#: 0.690 Hz; test_rescaled_controller_is_stable_at_every_rate,
#: test_the_rule_rejects_unstable_rates).
MIN_SAMPLE_RATE = 1.0
F_MAX = SimulationConfig.f_max  # actuator limit [m s^-2]
REF_LIMIT = SimulationConfig.alpha2 * SimulationConfig.gap  # alpha2 D of Eq. 20 [m]
#: Test-mass-to-electrode gap of the non-sensitive axis y [m]: 2.9 mm in the LISA
#: Pathfinder gravitational reference sensor (4.0 mm x, 2.9 mm y, 3.5 mm z; Dolesi et al.,
#: Class. Quantum Grav. 20, S99 (2003)); Eq. 20's alpha2 D on y uses it (docs/design.md).
Y_GAP = 2.9e-3
Y_REF_LIMIT = SimulationConfig.alpha2 * Y_GAP
#: Per-sample noise sigmas of SimulationConfig that follow the rate rule (Table 1 and f_B).
NOISE_FIELDS = ("sigma_m1", "sigma_m2", "sigma_acc", "sigma_ele", "fb_sigma")

#: Non-sensitive axes and spacecraft acceleration, by name (docs/decisions.md,
#: "Non-sensitive axes"): ``drag_free`` -- Table 1 (no f_B) and a PID holding y as a
#: drag-free suspension loop would (the defaults of SimulationConfig and
#: ControllerSettings); ``round1`` -- the first round's f_B (1e-10 m s^-2 bias + 1e-10
#: m s^-2 white, frame s) and its 10x slower y PID.
#: Gains and ``fb_sigma`` are per sample at the paper's 10 Hz: :func:`config_at_rate`
#: converts them to the run's rate like every other 10 Hz value.
Y_AXES: dict[str, dict[str, Any]] = {
    "drag_free": {"fb_bias": SimulationConfig.fb_bias, "fb_sigma": SimulationConfig.fb_sigma,
                  "y_gains": ControllerSettings.y_gains,
                  "y_derivative_filter": ControllerSettings.y_derivative_filter},
    "round1": {"fb_bias": (1e-10, 1e-10), "fb_sigma": 1e-10, "y_gains": (0.005, 1e-5, 1.0),
               "y_derivative_filter": 0.0},
}  # fmt: skip


# --------------------------------------------------------------------------- the rate rule


def config_at_rate(sample_rate: float = PAPER_RATE, noise_scale: float = 1.0,
                   y_axes: str | None = None, **fields: Any) -> SimulationConfig:  # fmt: skip
    """:class:`SimulationConfig` at ``sample_rate`` by the one sample-rate rule.

    Noise: every per-sample sigma of :data:`NOISE_FIELDS` (Table 1 at 10 Hz, and f_B)
    times ``noise_scale * sqrt(fs / 10 Hz)``: white noise of one-sided ASD ``S`` has the
    per-sample sigma ``S sqrt(fs / 2)``, so the ASDs stay those of the 10 Hz design.
    Control: the per-sample incremental-PID gains (sensitive and non-sensitive axes) are
    rescaled by :func:`tmopt.physics.control.rate_scaled_gains` to keep the continuous
    gains of the 10 Hz design; the loops are stable from :data:`MIN_SAMPLE_RATE` to 1 kHz
    (test_rescaled_controller_is_stable_at_every_rate) and slower rates are rejected.  At
    10 Hz and ``noise_scale`` 1 this is ``SimulationConfig(**fields)`` exactly.

    Args:
        sample_rate: Sampling rate fs [Hz], in [MIN_SAMPLE_RATE, inf).
        noise_scale: Factor on every noise sigma, in [0, inf).
        y_axes: A name of :data:`Y_AXES` (non-sensitive-axis PID and spacecraft
            acceleration f_B), or None for ``control``'s y loop and the f_B fields as
            given (default: none).  ``fb_bias`` / ``fb_sigma`` given explicitly override
            the named setting's f_B.
        fields: Any other :class:`SimulationConfig` field (duration, controller,
            stiffness, geometry, record, ramp_in, rls_columns, ...).  ``control`` and the
            sigmas of :data:`NOISE_FIELDS`, when given, are those of the 10 Hz design and
            are rescaled like the defaults.
    """
    _check_sample_rate(sample_rate)
    if not (isinstance(noise_scale, (int, float)) and math.isfinite(noise_scale)
            and noise_scale >= 0):  # fmt: skip
        raise ValueError(f"noise_scale must be finite and in [0, inf); got {noise_scale!r}")
    fs = float(sample_rate)
    scale = noise_scale * math.sqrt(fs / PAPER_RATE)
    design = SimulationConfig()  # the 10 Hz design's defaults
    control = fields.pop("control", design.control)
    if y_axes is not None:
        if y_axes not in Y_AXES:
            raise ValueError(f"y_axes must be one of {sorted(Y_AXES)}; got {y_axes!r}")
        spec = Y_AXES[y_axes]
        control = replace(control, y_gains=spec["y_gains"],
                          y_derivative_filter=spec["y_derivative_filter"])  # fmt: skip
        fields = {"fb_bias": spec["fb_bias"], "fb_sigma": spec["fb_sigma"], **fields}
    ctl = replace(control, base_gains=rate_scaled_gains(control.base_gains, fs),
                  y_gains=rate_scaled_gains(control.y_gains, fs))  # fmt: skip
    noise = {k: fields.pop(k, getattr(design, k)) * scale for k in NOISE_FIELDS}
    return SimulationConfig(sample_rate=fs, control=ctl, **noise, **fields)


def _check_sample_rate(fs: Any) -> None:
    if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs >= MIN_SAMPLE_RATE):
        raise ValueError(f"sample_rate must be finite and in [{MIN_SAMPLE_RATE:g}, inf) Hz "
                         f"(the rescaled 10 Hz controller is unstable below 0.95 Hz); "
                         f"got {fs!r}")  # fmt: skip


# --------------------------------------------------------------------------- settings


def _per_axis(tm1: tuple[float, float], tm2: tuple[float, float]) -> tuple[float, ...]:
    """Two (x, y) pairs of TM1 and TM2 -> the :data:`AXES` order (TM1 x, TM2 x, TM1 y, TM2 y)."""
    return (tm1[0], tm2[0], tm1[1], tm2[1])


@dataclass(frozen=True)
class Settings:
    """Run settings; defaults are the paper's (Table 1, Sec. 4.1, Fig. 6 motion) and the
    simulator's physics options (docs/decisions.md).

    ``stiffness`` = (k1xx, k2xx, k1yy, k2yy) [s^-2], ``bias`` = (fD1x, fD2x, fD1y, fD2y)
    [m s^-2].  ``noise_scale`` multiplies every Table 1 noise and the f_B noise;
    at other sample rates the per-sample sigmas scale with sqrt(fs / 10 Hz) so the noise
    ASDs stay those of Table 1.  ``ramp_in`` [s] (raised-cosine start of every reference),
    ``rls_columns`` (a name of ``RLS_COLUMN_SETS`` or a tuple of theta names), ``y_axes``
    (a name of :data:`Y_AXES`) and ``jacobian`` (the FRBF-PID's plant-Jacobian sign) are
    the physics options of :class:`SimulationConfig` and ``ControllerSettings``.
    ``witnesses``: write the six ``sc_omega*`` channels in every recording (zeros when the
    spacecraft does not rotate), so their presence reveals nothing.
    """

    duration: float = SimulationConfig.duration
    sample_rate: float = SimulationConfig.sample_rate
    excitation: str = "paper"
    noise_scale: float = 1.0
    controller: str = "frbf_pid"
    stiffness: tuple[float, float, float, float] = _per_axis(
        SimulationConfig.stiffness_1, SimulationConfig.stiffness_2)
    bias: tuple[float, float, float, float] = _per_axis(
        SimulationConfig.bias_1, SimulationConfig.bias_2)
    ramp_in: float = SimulationConfig.ramp_in
    rls_columns: str | tuple[str, ...] = "sensitive"
    y_axes: str = "drag_free"
    jacobian: str = "plus"
    witnesses: bool = True
    description: str = ""

    def __post_init__(self) -> None:
        v = self.duration
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"duration must be a finite number in (0, inf); got {v!r}")
        _check_sample_rate(self.sample_rate)
        if self.duration * self.sample_rate < 64:
            raise ValueError(f"duration * sample_rate must be >= 64 samples; got "
                             f"{self.duration * self.sample_rate:g}")  # fmt: skip
        if not (math.isfinite(self.noise_scale) and 0 <= self.noise_scale <= 1e3):
            raise ValueError(f"noise_scale must be in [0, 1000]; got {self.noise_scale!r}")
        for name in ("stiffness", "bias"):
            v = tuple(getattr(self, name))
            if len(v) != 4 or not all(math.isfinite(x) for x in v):
                raise ValueError(f"{name} must be 4 finite numbers {list(AXES)}; got {v!r}")
        # the physics options (ramp_in, rls_columns, y_axes, jacobian): checked where they
        # are defined, by building the run's configuration (cheap; nothing is simulated)
        simulation_config(self, Geometry())


def simulation_config(settings: Settings, geometry: Geometry, **fields: Any) -> SimulationConfig:
    """The simulator's configuration for ``settings`` and the *true* geometry, by the
    sample-rate rule of :func:`config_at_rate`; ``fields`` are further
    :class:`SimulationConfig` fields at their 10 Hz values (e.g. the recording
    generator's spacecraft acceleration ``fb_bias`` / ``fb_sigma``)."""
    rls = settings.rls_columns
    return config_at_rate(
        settings.sample_rate, settings.noise_scale, y_axes=settings.y_axes,
        duration=float(settings.duration), controller=settings.controller,
        stiffness_1=(settings.stiffness[0], settings.stiffness[2]),
        stiffness_2=(settings.stiffness[1], settings.stiffness[3]),
        bias_1=(settings.bias[0], settings.bias[2]), bias_2=(settings.bias[1], settings.bias[3]),
        geometry=geometry,
        steady_after=min(SimulationConfig.steady_after, float(settings.duration)),
        control=ControllerSettings(jacobian=settings.jacobian),
        ramp_in=float(settings.ramp_in), rls_columns=rls if isinstance(rls, str) else tuple(rls),
        **fields,
    )  # fmt: skip


# --------------------------------------------------------------------------- excitation


def excitation(spec: str, duration: float, fs: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """References (ref1, ref2) of the sensitive axes, each (N,), from a spec string.

    * ``paper`` -- Fig. 6: ``5e-5 sin(2 pi t/300)``, ``3e-5 sin(2 pi t/500)``;
    * ``multisine:A@P[@phase],...;A@P,...`` -- Eq. 17 per TM (``;`` separates TM1 from
      TM2): amplitude A [m], period P [s], phase [rad]; ``x(0) = 0`` as in Eq. 17; two
      more ``;``-groups (``x1;x2;y1;y2``) move the non-sensitive axes too (an empty group
      or ``0@1`` holds that axis), see :func:`excitation_axes`;
    * ``chirp:A,f0,f1;A,f0,f1`` -- ``A sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))`` [Hz];
    * ``steps:A,P[,ramp];A,P[,ramp]`` -- levels +A, -A, +A, ... each held P s, reached by
      raised-cosine ramps of ``ramp`` s (default: the shortest ramp whose peak
      acceleration ``2 A pi^2 / (2 ramp^2)`` stays at 0.5 F_max, Eq. 20's alpha1);
    * ``none`` -- no motion (the loop holds both TMs at zero).

    Raises ValueError naming the spec when a reference leaves |x| <= 0.4 mm (alpha2 D,
    Eq. 20), needs more than F_max = 1e-7 m s^-2, or has a tone at/above Nyquist; and when
    the spec moves a non-sensitive axis (those callers need :func:`excitation_axes`).
    """
    refs, info = excitation_axes(spec, duration, fs)
    if np.any(refs[2:]):
        raise ValueError(f"excitation {spec!r}: it moves the non-sensitive axes; this caller "
                         "takes x1 and x2 only")  # fmt: skip
    return refs[0], refs[1], info


def excitation_axes(spec: str, duration: float, fs: float) -> tuple[np.ndarray, dict]:
    """References of x1, x2, y1, y2 (4, N) from a spec string (syntax: :func:`excitation`;
    only ``multisine`` takes the two non-sensitive-axis groups).  The y references obey
    Eq. 20 with the y gap :data:`Y_GAP` (``|y| <= alpha2 D_y``) and the same F_max."""
    t = np.arange(int(round(duration * fs))) / fs
    kind, _, body = spec.partition(":")
    kind = kind.strip().lower()
    makers = {"paper": _paper, "multisine": _multisine, "chirp": _chirp, "steps": _steps,
              "none": _none}  # fmt: skip
    if kind not in makers:
        raise ValueError(f"excitation {spec!r}: kind must be one of {sorted(makers)}")
    try:
        refs, info = makers[kind](body, t, fs)
    except (ValueError, IndexError) as exc:
        raise ValueError(f"excitation {spec!r}: {exc}") from None
    while len(refs) < 4:
        refs.append(np.zeros_like(t))
    names = ("TM1", "TM2", "TM1 y", "TM2 y")
    for k, r in enumerate(refs):
        limit = REF_LIMIT if k < 2 else Y_REF_LIMIT
        if np.abs(r).max() > limit:
            raise ValueError(f"excitation {spec!r}: {names[k]} reference reaches "
                             f"{np.abs(r).max():.3g} m > {limit:g} m (alpha2 D, Eq. 20)")
    return np.array(refs), {"spec": spec, "kind": kind, **info}


def _tm_parts(body: str, n_fields: tuple[int, ...],
              groups: tuple[int, ...] = (2,)) -> list[list[list[float]]]:  # fmt: skip
    tms = body.split(";")
    if len(tms) not in groups:
        raise ValueError("give both test masses, separated by ';'" if groups == (2,) else
                         "give both test masses, separated by ';' (x1;x2), or the four "
                         "axes x1;x2;y1;y2")  # fmt: skip
    out = []
    for tm in tms:
        comps = []
        for comp in (tm.split(",") if tm.strip() else []):
            vals = [float(v) for v in comp.replace("@", " ").split()]
            if len(vals) not in n_fields:
                raise ValueError(f"component {comp!r} needs {' or '.join(map(str, n_fields))} "
                                 "numbers")  # fmt: skip
            comps.append(vals)
        out.append(comps)
    return out


def _tm_values(body: str, n_fields: tuple[int, ...]) -> list[list[float]]:
    """``v,v,v;v,v,v``: one comma-separated parameter list per test mass."""
    tms = body.split(";")
    if len(tms) != 2:
        raise ValueError("give both test masses, separated by ';'")
    out = [[float(v) for v in tm.split(",")] for tm in tms]
    for vals in out:
        if len(vals) not in n_fields:
            raise ValueError(f"{vals} needs {' or '.join(map(str, n_fields))} numbers")
    return out


def _sines(comps: list[list[float]], t: np.ndarray, fs: float) -> tuple[np.ndarray, float]:
    x = np.zeros_like(t)
    acc = 0.0
    for comp in comps:
        a, period, phase = comp[0], comp[1], comp[2] if len(comp) > 2 else 0.0
        if a < 0 or period <= 0:
            raise ValueError(f"amplitude must be >= 0 and period > 0; got {comp}")
        w = 2 * math.pi / period
        if w >= math.pi * fs:
            raise ValueError(f"period {period} s is at/above Nyquist for {fs} Hz")
        x += a * (np.sin(w * t + phase) - math.sin(phase))  # Eq. 17 with x(0) = 0
        acc += a * w * w
    return x, acc


def _paper(body: str, t: np.ndarray, fs: float) -> tuple[list[np.ndarray], dict]:
    if body:
        raise ValueError("'paper' takes no parameters")
    return _multisine("5e-5@300;3e-5@500", t, fs)


def _multisine(body: str, t: np.ndarray, fs: float) -> tuple[list[np.ndarray], dict]:
    refs, info = [], {}
    keys = ("tm1", "tm2", "tm1_y", "tm2_y")
    for k, comps in enumerate(_tm_parts(body, (2, 3), (2, 4))):
        x, acc = _sines(comps, t, fs)
        _check_accel(acc, k % 2 + 1)
        refs.append(x)
        info[keys[k]] = [{"amplitude_m": c[0], "period_s": c[1],
                          "phase_rad": c[2] if len(c) > 2 else 0.0} for c in comps]  # fmt: skip
    return refs, info


def _check_accel(acc: float, k: int) -> None:
    if acc > F_MAX:
        raise ValueError(f"TM{k} needs sum A w^2 = {acc:.3g} m s^-2 > F_max = {F_MAX:g}")


def _chirp(body: str, t: np.ndarray, fs: float) -> tuple[list[np.ndarray], dict]:
    refs, info = [], {}
    span = t[-1] + 1 / fs
    for k, vals in enumerate(_tm_values(body, (3,)), start=1):
        a, f0, f1 = vals
        if a < 0 or f0 < 0 or f1 < 0 or max(f0, f1) >= fs / 2:
            raise ValueError(f"chirp needs A >= 0 and 0 <= f0, f1 < {fs / 2} Hz; got {vals}")
        _check_accel(a * (2 * math.pi * max(f0, f1)) ** 2, k)
        refs.append(a * np.sin(2 * math.pi * (f0 * t + (f1 - f0) * t**2 / (2 * span))))
        info[f"tm{k}"] = {"amplitude_m": a, "f0_hz": f0, "f1_hz": f1}
    return refs, info


def _steps(body: str, t: np.ndarray, fs: float) -> tuple[list[np.ndarray], dict]:
    refs, info = [], {}
    for k, vals in enumerate(_tm_values(body, (2, 3)), start=1):
        a, hold = vals[:2]
        # default: peak acceleration A pi^2 / ramp^2 of a 2A raised cosine = 0.5 F_max
        ramp = vals[2] if len(vals) > 2 else math.pi * math.sqrt(2 * a / F_MAX)
        if a < 0 or hold <= 0 or ramp <= 0 or ramp > hold:
            raise ValueError(f"steps need A >= 0 and 0 < ramp <= hold; got {vals}")
        _check_accel(a * math.pi**2 / ramp**2, k)  # peak of a raised-cosine of height 2A
        refs.append(_step_train(t, a, hold, ramp))
        info[f"tm{k}"] = {"amplitude_m": a, "hold_s": hold, "ramp_s": ramp}
    return refs, info


def _step_train(t: np.ndarray, a: float, hold: float, ramp: float) -> np.ndarray:
    """0 -> +A (first ramp, height A), then -A, +A, ... each switch a raised-cosine ramp."""
    x = np.zeros_like(t)
    level, target, start = 0.0, a, 0.0
    while start <= t[-1]:  # switches at 0, hold, 2 hold, ...
        s = np.clip((t - start) / ramp, 0.0, 1.0)
        x += (target - level) * 0.5 * (1 - np.cos(np.pi * s))
        level, target, start = target, -target, start + hold
    return x


def _none(body: str, t: np.ndarray, fs: float) -> tuple[list[np.ndarray], dict]:
    if body:
        raise ValueError("'none' takes no parameters")
    return [np.zeros_like(t), np.zeros_like(t)], {}
