"""Shared machinery of the effect catalogue: the :class:`Effect` base class, what it reads
and writes on both sides, and the registry.

One module of this package per physical effect, holding one :class:`Effect` subclass that
says everything about it in one place:

* **injection** (generator side) -- ``inject(injection, builder)`` turns an
  :class:`Injection` (name, magnitude in physical units, channel, onset/duration, options)
  into the simulator's generic hooks (:class:`tmopt.physics.simulator.Perturbations`),
  a changed true geometry, or a transform of a recorded channel, through a
  :class:`Builder`, and returns the true parameters for the truth file; class attributes
  ``parameter``, ``unit``, ``limit`` (allowed ``|magnitude|``), ``signed``, ``channels``,
  ``default_channel``, ``windowed``, ``options``;
* **regression** (diagnosis side) -- ``candidates(ctx)`` turns a recording into
  :class:`Candidate` variants: the regressors the effect adds to the per-axis equation
  ``acc_a - f_a = k_a x_a + f_D,a - (P f_B)_a + [effect]`` (seen in the two f_B-free
  combinations, :func:`tmopt.mismatch.fit.axis_column`) or to the kinematic consistency
  residual, with parameter names, units and the words of the explanation; ``untestable``
  says when a recording cannot test it; ``explanation``, ``needs``, ``group``,
  ``profiled``;
* **ranges** -- ``plausible``: the largest physically plausible magnitude (a prior used only
  to say whether an excitation can reveal the effect at all); ``limit``: the largest the
  generator accepts;
* **calibration** -- :class:`Calibration`: the generator's ``near``/``large`` magnitudes
  (detectability SNR ~5 / ~50 under the paper's settings) and the channel and options
  they were calibrated on; ``noise_like`` picks the detectability statistic.

Adding an effect = adding one module here (its name is the effect's name); a new *kind* of
perturbation also needs its slot in ``Perturbations`` and the closed-loop kernel.

The :class:`Builder` is an injection's only contact with the simulator: another generator
(e.g. one imitating a foreign simulator) can pass its own object with the same members
(``n``, ``fs``, ``seed``, ``time``, ``duration``, ``geometry``, ``series``, ``const``,
``post``) and map the named ``Perturbations`` slots onto its own physics.

For experiment design (an information matrix of a planned excitation), ``candidates`` of
an effect that is not ``profiled`` reads only ``ctx.data`` and ``ctx.basis``:
:meth:`Effect.regressors` gives its columns for any (e.g. simulated, noise-free) data.
Profiled effects (glitch onset/width, quantisation step, noise spectrum) search
parameters on the current residual and report a trials factor (Bonferroni over the
search) so that their p-values stay valid.
"""

from __future__ import annotations

import importlib
import math
import pkgutil
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from tmopt.mismatch.fit import (
    Column,
    Data,
    axis_column,
    fb_projection,
    kinematic_series,
    tone_instrument,
)
from tmopt.mismatch.noise_model import NoiseModel
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import AXES
from tmopt.physics.simulator import Perturbations

__all__ = ["AXES", "PARTNER", "TMS", "Calibration", "Candidate", "Context", "Effect",
           "Injection", "Builder", "discover"]  # fmt: skip

#: The other in-plane axis of the same test mass.
PARTNER = {"x1": "y1", "y1": "x1", "x2": "y2", "y2": "x2"}
TMS = {"x1": "TM1 sensitive axis", "x2": "TM2 sensitive axis",
       "y1": "TM1 non-sensitive axis", "y2": "TM2 non-sensitive axis"}  # fmt: skip


# --------------------------------------------------------------------------- generator side


@dataclass(frozen=True)
class Injection:
    """One concealed effect.  ``channel`` None = the effect's default; ``onset``/``duration``
    [s] from the first sample window the effect where meaningful (None = effect default);
    ``options`` are effect-specific (see each effect's module)."""

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
        """The (rows, N) time series of ``Perturbations`` slot ``name`` (zeros at first)."""
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


@dataclass(frozen=True)
class Calibration:
    """Calibrated magnitudes of an effect (docs/mismatch-generator.md, "Magnitudes"): ``near``
    gives a detectability SNR of about 5, ``large`` about 50, for the default settings
    (paper excitation, 1200 s, 10 Hz, Table 1 noise; seed 101), on ``channel`` with
    ``options``; ``snr_*`` are the SNRs reached and ``family`` the residual family of the
    largest SNR (output of ``python -m tmopt.mismatch.generate --calibrate``; recomputed for
    issue 17, whose 90 s ramp-in removed the start-up transient)."""

    channel: str
    options: Mapping[str, Any]
    near: float | None
    snr_near: float | None
    large: float | None
    snr_large: float | None
    family: str


# --------------------------------------------------------------------------- diagnosis side


@dataclass
class Context:
    """What the candidates may look at: the data, the f_B-free basis, current residuals
    (``eq_residual`` and ``eq_noise`` are read by profiled effects only)."""

    data: Data
    basis: np.ndarray
    eq_residual: np.ndarray | None = None
    eq_noise: NoiseModel | None = None

    @property
    def fb_hat(self) -> np.ndarray:
        """Per-sample least-squares f_B^s (2, N) from the four axes (sign of Eqs. 1-2)."""
        p = fb_projection(self.data.geometry)
        return -np.linalg.pinv(p) @ (self.data.acc - self.data.force)


@dataclass
class Candidate:
    """One variant of an effect: its regressors and how to report it."""

    effect: str
    channel: str
    group: str  # "equation" | "kinematic" | "noise"
    params: list[str]
    units: list[str]
    columns: list[Column] = field(default_factory=list)
    plausible: float | None = None  # largest plausible |parameter| (identifiability prior)
    trials: float = 1.0  # Bonferroni factor of a parameter search (look-elsewhere)
    fixed: dict = field(default_factory=dict)  # searched (profiled) parameters
    derived: dict = field(default_factory=dict)  # how to report a combination of coefs
    text: str = ""
    twin: Column | None = None  # the same parameter's prediction in the kinematic group
    #: Is the twin part of the candidate's test (:func:`~tmopt.mismatch.diagnose._joint`:
    #: one parameter seen by both groups)?  False: the twin only joins the kinematic fit
    #: once the candidate is selected (with its own free coefficient, unless ``twin_tie``).
    twin_tested: bool = True
    #: Set: the twin's kinematic coefficient is *tied* to the equation's parameter, not
    #: free.  Maps ``p``, the sum of the candidate's equation coefficients, to the twin's
    #: kinematic term (4, rows); once selected that term at the joint estimate of ``p``
    #: is an offset of the kinematic target (``diagnose._tied_offset``), not a column.
    twin_tie: Callable[[float], np.ndarray] | None = None
    #: Set (kinematic candidates): how the parameter p moves a stiffness term's position,
    #: ``eq_tie(p) -> (axis, shift (N,))``; once selected, that axis' stiffness column of
    #: Eq. 10 acts on ``x_eq + shift`` (``diagnose._position_shift``).
    eq_tie: Callable[[float], tuple[int, np.ndarray]] | None = None
    n_searched: int = 0  # parameters found by search (counted in the BIC penalty)
    #: Its GLR's own calibrated null (a key of ``calibration.LOWFREQ_NULL``; "": chi^2):
    #: a shape living in the record's lowest bins, where the coloured noise model rests on
    #: a handful of periodogram bins and the 1/f^2 background inflates the statistic;
    #: used when ``Settings.lowfreq`` names it (``diagnose.lowfreq_glr``).
    null: str = ""
    #: Axis whose motion drives the effect (a coupling's source): identifiability calls
    #: it "not excited" when that axis has no excitation tones -- its readout is then
    #: mostly readout noise, which is not motion.
    source_axis: int | None = None

    @property
    def key(self) -> str:
        return f"{self.effect}[{self.channel}]"

    def physical(self, coef: np.ndarray, cov: np.ndarray) -> dict[str, tuple[float, float]]:
        """Fitted coefficients -> reported parameters ``{name: (value, sigma)}``.

        ``derived``: ``("sum", h)`` -- the delay ``tau = h sum c_j`` (FIR group delay);
        ``("ratio", None)`` -- a readout scale fitted on the measured (scaled) channel,
        ``e = b/(1-b)`` (delta method for sigma); otherwise one coefficient per parameter.
        """
        out = {}
        if not self.derived:
            for i, name in enumerate(self.params):
                out[name] = (float(coef[i]), float(math.sqrt(max(cov[i, i], 0.0))))
            return out
        for name, (kind, arg) in self.derived.items():
            if kind == "sum":
                out[name] = (float(arg * coef.sum()), float(arg * math.sqrt(max(cov.sum(), 0))))
            else:
                b, sb = float(coef[0]), math.sqrt(max(cov[0, 0], 0.0))
                out[name] = (b / (1 - b), sb / (1 - b) ** 2)
        return out


# --------------------------------------------------------------------------- the effect


class Effect:
    """One physical effect, both sides; see the module docstring for the attributes.

    Subclasses set the class attributes and implement ``inject`` and ``candidates``.
    """

    name: ClassVar[str]
    #: Place in the catalogue (report, listing and benchmark order); ties by name.
    position: ClassVar[int] = 1000

    # generator side: what the magnitude is, where it may act
    parameter: ClassVar[str]
    unit: ClassVar[str]
    limit: ClassVar[float]
    signed: ClassVar[bool] = True
    channels: ClassVar[tuple[str, ...]] = AXES
    default_channel: ClassVar[str] = "x1"
    windowed: ClassVar[bool] = False
    options: ClassVar[dict[str, Any]] = {}
    #: Largest |value| of fitted parameters other than ``parameter`` (by name prefix) that
    #: physics allows: past it the explanation is beyond physics
    #: (:func:`tmopt.mismatch.plausibility.implausible_effects`).
    side_limits: ClassVar[dict[str, float]] = {}

    # diagnosis side
    group: ClassVar[str] = "equation"
    explanation: ClassVar[str]
    needs: ClassVar[str]
    profiled: ClassVar[bool] = False  # parameters searched on the residual (costly)
    plausible: ClassVar[float | None] = None
    #: May be selected more than once in one recording (e.g. several glitches).
    repeatable: ClassVar[bool] = False

    # calibration
    calibration: ClassVar[Calibration | None] = None
    #: Noise-like: detectability is the expected excess power, not a matched filter.
    noise_like: ClassVar[bool] = False
    #: Slow in time (a ramp): under coloured noise its statistic is inflated by the 1/f^2
    #: acceleration noise's random-walk 'ramps' (the joint stage's drift family).
    slow_in_time: ClassVar[bool] = False
    #: Its columns are built from witness channels measured outside the test-mass loop
    #: (the spacecraft's attitude), not from a test mass's own motion or force: they carry
    #: none of the TM noise.  Its statistic is also read under the noise model estimated
    #: with it fitted (:func:`tmopt.mismatch.diagnose._witness_alternative`): estimated
    #: without it, a slow one's power is taken into the spectrum and whitened away.
    witness_driven: ClassVar[bool] = False

    # ---- generator side ---------------------------------------------------------------

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        """Add the effect to ``b``; return its true parameters (truth file)."""
        raise NotImplementedError

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

    def source(self, ch: str, opt: dict[str, Any]) -> str:
        """Option ``source``: the other axis of a coupling (default: :data:`PARTNER`)."""
        src = PARTNER[ch] if opt["source"] is None else opt["source"]
        if src not in AXES or src == ch:
            raise ValueError(f"{self.name}: option 'source' must be one of "
                             f"{[a for a in AXES if a != ch]}; got {src!r}")  # fmt: skip
        return src

    def option(self, key: str, value: Any, lo: float, hi: float) -> float:
        """A numeric option in ``[lo, hi]``."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
            raise ValueError(f"{self.name}: option {key!r} must be a number in [{lo:g}, {hi:g}]; "
                             f"got {value!r}")  # fmt: skip
        return float(value)

    def choice(self, key: str, value: Any, allowed: tuple[str, ...]) -> str:
        """A string option among ``allowed``."""
        if value not in allowed:
            words = " or ".join(repr(a) for a in allowed)
            raise ValueError(f"{self.name}: option {key!r} must be {words}; got {value!r}")
        return value

    # ---- diagnosis side ---------------------------------------------------------------

    def candidates(self, ctx: Context) -> list[Candidate]:
        """The effect's variants (one per test mass / axis / channel pair) for ``ctx``."""
        raise NotImplementedError

    def shape_check(self, ctx: Context, cand: Candidate) -> list[Column]:
        """Columns that a selected ``cand`` of this effect must *not* need (empty: no
        check).  The effect's name promises a shape (a drift is linear in time); when
        these columns, added to the final model, are significant at
        :data:`tmopt.mismatch.calibration.SHAPE_ALPHA` (one test with
        :meth:`shape_search`'s shapes, Bonferroni), the residual on that channel has
        the effect's kind of structure but not its shape (a slow bias modulation read
        as a linear drift), and the name is reported ambiguous, the channel unexplained."""
        return []

    def shape_search(self, ctx: Context, cand: Candidate) -> list[Candidate]:
        """The shape check's searched half: shapes with a searched parameter (an onset)
        that a selected ``cand`` must not need either, each a candidate carrying its
        search as ``trials`` (empty: none).  Judged with :meth:`shape_check`'s columns
        as one test (Bonferroni, :func:`tmopt.mismatch.diagnose.shape_misfits`)."""
        return []

    @staticmethod
    def changes_in_time(ctx: Context, cand: Candidate,
                        stiffness: bool = False) -> list[Candidate]:  # fmt: skip
        """The searched shape check of an effect that promises a *linear* change in time:
        the best step and relaxation of the force on ``cand``'s axis, or with
        ``stiffness`` the best stiffness step (:func:`tmopt.mismatch.generic.shape_rivals`).
        A ramp beside them leaves little (a step fits 3/4 of a centred ramp's energy,
        which the ramp then has); a change that starts late in the record does not."""
        from tmopt.mismatch import generic  # generic imports this module

        return generic.shape_rivals(ctx, cand.channel, stiffness)

    @staticmethod
    def curvature_in_time(ctx: Context, cand: Candidate,
                          carrier: np.ndarray | None = None) -> list[Column]:  # fmt: skip
        """The shape check of an effect that promises a *linear* change in time: Legendre
        P2 and P3 of the record's time (u in [-1, 1]), times ``carrier`` (N,) -- the
        regressor the change multiplies (none for a force, ``x_a`` for a stiffness) --, on
        ``cand``'s axis.  A linear change leaves nothing for them; a step, a relaxation or
        a slow modulation does (an odd P3 takes a step near the middle, an even P2 one
        near either end).  Two columns, so the check is one 2-dof test."""
        d = ctx.data
        u = 2.0 * d.centred_time / max(float(np.ptp(d.time)), d.dt)
        a = AXES.index(cand.channel)
        c = np.ones_like(u) if carrier is None else carrier
        return [Column(f"shape:{cand.key}:P{k}", axis_column(ctx.basis, a, poly * c))
                for k, poly in ((2, 1.5 * u**2 - 0.5), (3, 2.5 * u**3 - 1.5 * u))]  # fmt: skip

    def same_event(self, a: Candidate, b: Candidate) -> bool:
        """Are two selected candidates of this (repeatable) effect pieces of one physical
        event, reported and counted once (:func:`tmopt.mismatch.diagnose.events`)?"""
        return False

    def untestable(self, ctx: Context) -> str | None:
        """Why this recording cannot test the effect at all (e.g. missing channels)."""
        return None

    def regressors(self, data: Data, basis: np.ndarray) -> list[Candidate]:
        """Candidates of a non-profiled effect for any data (no residual needed): the
        columns an information-matrix computation of a planned excitation needs."""
        if self.profiled:
            raise ValueError(f"{self.name}: its parameters are searched on a residual; "
                             "it has no residual-free regressors")  # fmt: skip
        return self.candidates(Context(data, basis))

    def equation_candidate(self, channel: str, param: str, unit: str, series: np.ndarray,
                           ctx: Context, axis: int,
                           plausible: float | None) -> Candidate:  # fmt: skip
        """One-regressor candidate ``param * series`` in axis ``axis``'s equation."""
        col = Column(f"{self.name}[{channel}]", axis_column(ctx.basis, axis, series))
        text = self.explanation.format_map(_Blank(ch=channel, where=TMS.get(channel, "")))
        return Candidate(self.name, channel, "equation", [param], [unit], [col], plausible,
                         text=text)  # fmt: skip

    def kinematic_candidate(self, channel: str, param: str, ctx: Context, a: int, b: int,
                            text: str) -> Candidate:  # fmt: skip
        """One-regressor candidate in readout a's kinematic residual, driven by axis b."""
        col = kinematic_column(f"{self.name}[{channel}]", ctx, a, b)
        return Candidate(self.name, channel, "kinematic", [param], ["1"], [col], self.plausible,
                         text=text)  # fmt: skip


class _Blank(dict):
    """Format mapping that leaves unknown placeholders for the caller to fill."""

    def __missing__(self, key: str) -> str:
        return "{" + key + "}"


def kinematic_column(name: str, ctx: Context, a: int, b: int, sign: float = 1.0) -> Column:
    """Kinematic regressor ``sign h^2 (acc_b,n + acc_b,n-1)/2`` on readout channel a, with
    its excitation-tone part as instrument where the regressor is not exogenous (the own
    axis, a == b: a's loop feeds readout a's noise into ``acc_a``); for b != a the regressor
    is its own instrument (:data:`UNEXCITED_SOURCE_OLS`, :data:`EXCITED_SOURCE_OLS`)."""
    d = ctx.data
    rows = d.kin_index
    arr = np.zeros((4, rows.size))
    inst = np.zeros((4, rows.size))
    arr[a] = sign * kinematic_series(d, b)
    if a != b and (EXCITED_SOURCE_OLS if d.tones(b) else UNEXCITED_SOURCE_OLS):
        return Column(name, arr, None, (), a)  # the regressor is its own instrument
    inst[a] = tone_instrument(arr[a], d.time[rows], d.tones(b))
    return Column(name, arr, inst, tuple(d.tones(b)), a)


#: A readout term driven by *another* axis b that carries no excitation is tested with the
#: plain regressor ``h^2 acc_b`` (least squares, no instrument): b's acceleration then holds
#: only b's own noise, which the loops do not feed into readout a, so it is exogenous there
#: (docs/mismatch.md 9.12; the null, on clean recordings of both simulators:
#: experiments/mismatch_open_source_null.py).  Off, such a term was untestable and a
#: cross-talk from a y axis moving with its noise alone was never seen (80000 set: 4 of the
#: 5 cross-talk misses).  The own axis (a readout scale, a == b) keeps its instrument: a's
#: loop feeds a's readout noise into acc_a.
UNEXCITED_SOURCE_OLS = True

#: The same for a source axis b that *is* excited (stop 42, docs/mismatch.md 9.18 (c)):
#: acc_b then holds b's tones beside b's noise motion, and neither holds readout a's noise,
#: so the plain regressor is exogenous as for an unexcited b.  With only its tone part as
#: instrument the test threw away the noise motion, most of the regressor's energy where
#: the y readouts are noisy: a displacement cross-talk y1 -> x1 of 2.3e-4 (`visible` 45)
#: had GLR 15.2 (dBIC 4.1, "no effect" beside it; f160086), 139.5 with the regressor.
EXCITED_SOURCE_OLS = True


# --------------------------------------------------------------------------- time profiles


def _check_window(name: str, inj: Injection, duration: float) -> None:
    if inj.onset is not None and not (math.isfinite(inj.onset) and 0 <= inj.onset < duration):
        raise ValueError(f"{name}: onset must be in [0, {duration:g}) s; got {inj.onset!r}")
    if inj.duration is not None and not (math.isfinite(inj.duration) and inj.duration > 0):
        raise ValueError(f"{name}: duration must be in (0, inf) s; got {inj.duration!r}")


def finite(t: float) -> float | None:
    """A window end for the truth file: None for 'until the end of the run'."""
    return t if math.isfinite(t) else None


def ramp(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """``clip(t - t0, 0, t1 - t0)``: a linear change from t0, held after t1."""
    return np.clip(t - t0, 0.0, t1 - t0)


def ramp_average(t: np.ndarray, h: float, t0: float, t1: float) -> np.ndarray:
    """Exact average of :func:`ramp` over each ``[t_n, t_n + h)``.

    Antiderivative of ``clip(s - t0, 0, L)`` (L = t1 - t0): ``u^2/2 + L max(s - t1, 0)``
    with ``u = clip(s - t0, 0, L)`` (the second term is absent when t1 is infinite).
    """
    span = t1 - t0

    def g(s: np.ndarray) -> np.ndarray:
        u = np.clip(s - t0, 0.0, span)
        tail = span * np.maximum(s - t1, 0.0) if math.isfinite(span) else 0.0
        return 0.5 * u**2 + tail

    return (g(t + h) - g(t)) / h


# --------------------------------------------------------------------------- the registry


def discover(package: str, path: Iterable[str]) -> tuple[Effect, ...]:
    """One instance of the :class:`Effect` defined in each module of ``package`` (all but
    ``base`` and private modules), in catalogue order (``position``, then name).

    Raises TypeError when a module defines no effect or several, or when the effect's
    name is not its module's name (one file, one effect, one name)."""
    found = []
    for info in pkgutil.iter_modules(list(path)):
        if info.name == "base" or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{package}.{info.name}")
        classes = [c for c in vars(module).values() if isinstance(c, type)
                   and issubclass(c, Effect) and c.__module__ == module.__name__]  # fmt: skip
        if len(classes) != 1:
            raise TypeError(f"{module.__name__} must define exactly one Effect; found "
                            f"{[c.__name__ for c in classes]}")  # fmt: skip
        effect = classes[0]()
        if getattr(effect, "name", None) != info.name:
            raise TypeError(f"{module.__name__}: the effect's name must be its module's "
                            f"name {info.name!r}; got {getattr(effect, 'name', None)!r}")
        found.append(effect)
    return tuple(sorted(found, key=lambda e: (e.position, e.name)))
