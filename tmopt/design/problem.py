"""The next-excitation design problem built from a diagnosis (a tmopt/pymoo Problem).

Decision variables: per free axis (x1, x2, y1, y2; option ``axes``), ``tones`` components
of Eq. 17's multi-sine -- amplitude as a fraction of the largest that Eq. 20 allows a
priori for that tone, ``min(alpha2 D / (2 k), alpha1 F_max / (k w^2))`` with k tones
(``|x| <= 2 sum A`` since x(0) = 0; the y gap is :data:`tmopt.physics.scenario.Y_GAP`),
so every design is a valid excitation spec; the period as a fraction of the log-period
range from ``period[0]`` to the longest of at least :data:`MIN_CYCLES` cycles in the
run (a slower tone is no line the diagnosis finds); phase [rad] -- and
the identification time (run duration) [s], rounded to ``duration_step`` so that designs
of one duration share one simulator batch.  Axes that are not free keep the ``base``
excitation's motion.

Constraints: Eq. 20 per axis on the *realised* closed-loop motion of the planned run
(``max |u| <= alpha1 F_max`` and ``max |r| <= alpha2 D``, as
:func:`tmopt.physics.objectives.eq20_realised` does for the sensitive axes; docs/decisions.md
"Eq. 20 on the realised motion"), normalised ``value / limit - 1 <= 0``; and per free
axis the line rule (:func:`line_violation`: every tone >= 2 cycles in the run and >= 2
frequency bins from the axis' other tones, so that the diagnosis' line search finds the
lines the prediction's instruments assume); constraint groups TM1 (priority 0, the test
mass whose stiffness is identified) and TM2.

Objectives (all minimised; the optimiser sees their log10): the predicted standard error
of k1xx [s^-2]; for each suspected effect the diagnosis flagged, the worst over its
flagged channels of ``sigma / plausible`` (the information model of
:mod:`tmopt.design.information` at the recording's noise level; below ``1 / z`` the
effect becomes detectable at the diagnosis' Bonferroni threshold z); and the
identification time [s].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from tmopt.design.information import NoiseLevel, Prediction, Target, predict
from tmopt.mismatch.fit import data_from_result, null_basis
from tmopt.physics.control import PAPER_RATE
from tmopt.physics.geometry import Geometry
from tmopt.physics.information import noise_free
from tmopt.physics.recording import AXES
from tmopt.physics.scenario import (
    REF_LIMIT,
    Y_REF_LIMIT,
    Settings,
    excitation_axes,
    simulation_config,
)
from tmopt.physics.simulator import SimulationConfig, simulate
from tmopt.problems.base import ConstraintGroup, ExpensiveProblem

__all__ = ["DesignSpace", "DesignProblem", "AXIS_LIMIT"]

#: alpha2 D of Eq. 20 per axis [m] (x: the paper's 4 mm gap; y: Y_GAP).
AXIS_LIMIT = {"x1": REF_LIMIT, "x2": REF_LIMIT, "y1": Y_REF_LIMIT, "y2": Y_REF_LIMIT}
#: Largest objective value (before the log) passed to an optimiser (for infinite standard
#: errors).
F_CAP = 1e30
#: The line rule of a planned run: every tone at least this many cycles in the run and
#: this many frequency bins (``1 / duration``) from every other tone of its axis.
MIN_CYCLES = 2.0
MIN_BINS = 2.0
#: alpha1 F_max of Eq. 20 [m s^-2].
ALPHA1_FMAX = SimulationConfig.alpha1 * SimulationConfig.f_max


@dataclass(frozen=True)
class DesignSpace:
    """What may vary: free axes, tones per axis, period and duration ranges [s]."""

    axes: tuple[str, ...] = AXES
    tones: int = 2
    period: tuple[float, float] = (30.0, 1500.0)
    duration: tuple[float, float] = (600.0, 2400.0)
    duration_step: float = 60.0
    base: str = "paper"

    def __post_init__(self) -> None:
        bad = [a for a in self.axes if a not in AXES]
        if not self.axes or bad or len(set(self.axes)) != len(self.axes):
            raise ValueError(f"axes must be distinct names from {list(AXES)}; got "
                             f"{list(self.axes)}")  # fmt: skip
        if not (isinstance(self.tones, int) and 1 <= self.tones <= 6):
            raise ValueError(f"tones must be an integer in [1, 6]; got {self.tones!r}")
        lo, hi = self.period
        if not (0 < lo < hi):
            raise ValueError(f"period must be a range 0 < lo < hi [s]; got {self.period!r}")
        lo, hi = self.duration
        if not (0 < lo <= hi and self.duration_step > 0):
            raise ValueError(f"duration must be a range 0 < lo <= hi [s] and duration_step "
                             f"> 0; got {self.duration!r}, {self.duration_step!r}")  # fmt: skip

    @property
    def n_var(self) -> int:
        return 3 * self.tones * len(self.axes) + 1

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        per = [(0.0, 1.0), (0.0, 1.0), (0.0, 2 * math.pi)]
        lo = [b[0] for _ in self.axes for _ in range(self.tones) for b in per]
        hi = [b[1] for _ in self.axes for _ in range(self.tones) for b in per]
        d0, d1 = self.duration
        return np.array(lo + [d0]), np.array(hi + [max(d1, d0 + 1e-9)])

    def duration_of(self, x: np.ndarray) -> float:
        d0, d1 = self.duration
        step = self.duration_step
        return float(np.clip(round(x[-1] / step) * step, d0, d1))

    def spec(self, x: np.ndarray, base_parts: dict[str, str]) -> str:
        """Decision vector -> the excitation spec of ``python -m tmopt.simulate``
        (``multisine:x1;x2;y1;y2``), free axes from ``x``, the others from the base."""
        parts = dict(base_parts)
        lo = math.log10(self.period[0])
        hi = math.log10(max(self.period[0], min(self.period[1],
                                                self.duration_of(x) / MIN_CYCLES)))
        k = 0
        for a in self.axes:
            comps = []
            for _ in range(self.tones):
                frac, where, ph = x[k : k + 3]
                k += 3
                logp = lo + float(where) * (hi - lo)
                w = 2 * math.pi / 10**logp
                amp = float(frac) * min(AXIS_LIMIT[a] / (2 * self.tones),
                                        ALPHA1_FMAX / (self.tones * w * w))
                if amp > 0:
                    comps.append(f"{amp:.6g}@{10**logp:.6g}@{float(ph):.6g}")
            parts[a] = ",".join(comps)
        return "multisine:" + ";".join(parts[a] for a in AXES)


def base_parts(spec: str, duration: float, fs: float) -> dict[str, str]:
    """Per-axis multi-sine groups of a base excitation (``paper`` or ``multisine:``)."""
    _, info = excitation_axes(spec, duration, fs)
    keys = {"x1": "tm1", "x2": "tm2", "y1": "tm1_y", "y2": "tm2_y"}
    out = {}
    for a, key in keys.items():
        comps = info.get(key, [])
        if not isinstance(comps, list):
            raise ValueError(f"base excitation {spec!r} must be 'paper' or 'multisine:...'")
        out[a] = ",".join(f"{c['amplitude_m']:.6g}@{c['period_s']:.6g}@{c['phase_rad']:.6g}"
                          for c in comps)  # fmt: skip
    return out


class DesignProblem(ExpensiveProblem):
    """Next excitation for ``targets`` (see the module docstring).

    Args:
        targets: Effect parameters the diagnosis could not identify.
        noise: Noise models estimated from the recording.
        sample_rate: Of the planned run [Hz] (the recording's).
        geometry: Nominal geometry (the recording's attributes).
        stiffness, bias: The identified model the planned run is simulated with.
        space: The design space.
        z: The diagnosis' detection threshold (sqrt of the Bonferroni chi^2_1 quantile).
        controller, ramp_in: Physics options of the planned run (None: the run settings'
            defaults, :class:`tmopt.physics.scenario.Settings`).
    """

    def __init__(self, targets: Sequence[Target], noise: NoiseLevel,
                 sample_rate: float = PAPER_RATE,
                 geometry: Geometry | None = None,
                 stiffness: tuple[float, float, float, float] = (1e-7, 1e-7, 1e-7, 1e-7),
                 bias: tuple[float, float, float, float] = (1e-10, 1e-10, 1e-10, 1e-10),
                 space: DesignSpace | None = None, z: float = 4.0,
                 controller: str | None = None,
                 ramp_in: float | None = None) -> None:  # fmt: skip
        self.targets = list(targets)
        self.noise = noise
        self.space = DesignSpace() if space is None else space
        self.geometry = Geometry() if geometry is None else geometry
        self.z = float(z)
        self.settings = Settings(duration=self.space.duration[1], sample_rate=sample_rate,
                                 controller=controller or Settings.controller,
                                 stiffness=tuple(stiffness), bias=tuple(bias),
                                 ramp_in=Settings.ramp_in if ramp_in is None else ramp_in)
        self.base = base_parts(self.space.base, self.space.duration[1], sample_rate)
        self.basis = null_basis(self.geometry)
        self.effects = sorted({t.effect for t in self.targets})
        self.physical_names = ["se_k1xx"] + [f"ratio_{e}" for e in self.effects] + ["duration_s"]
        names = [f"log10_{n}" for n in self.physical_names]
        cons = [f"eq20_{kind}_{a}" for a in AXES for kind in ("force", "position")]
        cons += [f"lines_{a}" for a in AXES]
        # constraint columns: 2 per axis in AXES order (x1, x2, y1, y2), then one per axis
        groups = [ConstraintGroup("TM1", (0, 1, 4, 5, 8, 10), 0),
                  ConstraintGroup("TM2", (2, 3, 6, 7, 9, 11), 1)]  # fmt: skip
        lo, hi = self.space.bounds()
        super().__init__(n_var=self.space.n_var, n_obj=len(names), n_ieq_constr=len(cons), xl=lo,
                         xu=hi, name="next_excitation", constraint_groups=groups,
                         objective_names=names, constraint_names=cons)  # fmt: skip

    # ------------------------------------------------------------------ one design

    def spec(self, x: np.ndarray) -> str:
        return self.space.spec(np.asarray(x, float), self.base)

    def simulate(self, specs: Sequence[str], duration: float):
        """Noise-free closed-loop runs of ``specs`` (one duration), batched."""
        fs = self.settings.sample_rate
        return self.simulate_refs(np.array([_unchecked_refs(s, duration, fs) for s in specs]))

    def simulate_refs(self, refs: np.ndarray):
        """Noise-free closed-loop runs of references (B, 4, N) at the recording's rate."""
        duration = refs.shape[2] / self.settings.sample_rate
        cfg = noise_free(simulation_config(replace(self.settings, duration=duration),
                                           self.geometry))  # fmt: skip
        return simulate(refs[:, 0], refs[:, 1], cfg, 0, ref_y=(refs[:, 2], refs[:, 3]))

    def predictions(self, result, specs: Sequence[str] | None = None) -> list[Prediction]:
        """Predicted standard errors of every run of ``result``; ``specs`` (the runs'
        multi-sine specs) give the excitation lines the diagnosis will find: the tones of
        at least two cycles in the run (a slower one is no resolved line)."""
        out = []
        for i in range(result.batch_size):
            data = data_from_result(result, i)
            known = None if specs is None else resolved_tones(specs[i], data.time.size / data.fs)
            out.append(predict(data, self.basis, self.targets, self.noise, known))
        return out

    def constraints(self, result, specs: Sequence[str]) -> np.ndarray:
        """Eq. 20 per axis on the realised run, ``value / limit - 1`` (B, 8), then the
        line rule of every free axis (:func:`line_violation`; B, 4) -- ``specs``: the
        runs' multi-sine specs."""
        cfg = result.config
        x, u = result.max_abs_position, result.max_abs_command
        cols = []
        for k, a in enumerate(AXES):
            cols.append(u[:, k] / (cfg.alpha1 * cfg.f_max) - 1)
            cols.append(x[:, k] / AXIS_LIMIT[a] - 1)
        g = np.stack(cols, axis=1)
        g = np.where(result.diverged[:, None], np.maximum(g, 1.0), g)
        duration = result.config.duration
        free = [a in self.space.axes for a in AXES]
        lines = np.array([[v if f else -1.0 for v, f in zip(line_violation(s, duration), free)]
                          for s in specs])  # fmt: skip
        return np.hstack([g, lines])

    def objectives(self, pred: Prediction, duration: float) -> np.ndarray:
        row = [pred.se["k1xx"]]
        for e in self.effects:
            row.append(max(pred.judged(t.key) / t.plausible for t in self.targets
                           if t.effect == e))  # fmt: skip
        row.append(duration)
        return np.array(row)

    def _evaluate(self, x, out, *args, **kwargs):
        x = np.atleast_2d(np.asarray(x, float))
        f = np.empty((x.shape[0], self.n_obj))
        g = np.empty((x.shape[0], self.n_ieq_constr))
        durations = np.array([self.space.duration_of(r) for r in x])
        for d in np.unique(durations):
            rows = np.flatnonzero(durations == d)
            specs = [self.spec(x[i]) for i in rows]
            res = self.simulate(specs, float(d))
            g[rows] = self.constraints(res, specs)
            for i, pred in zip(rows, self.predictions(res, specs)):
                f[i] = self.objectives(pred, float(d))
        # the optimiser sees log10 of every objective: standard errors span orders of
        # magnitude, and a surrogate (the MGSAEA family's GP) or a normalisation by the
        # archive's range needs them on one scale; an unexcited target has an infinite
        # standard error: a finite cap keeps crowding distances and surrogate fits
        # defined (the Pareto ranking is unchanged by either)
        out["F"] = np.log10(np.minimum(f, F_CAP))
        out["G"] = g


def _tones_of(spec: str) -> list[list[tuple[float, float]]]:
    """(amplitude, period [s]) of every component, per axis group of a multi-sine spec."""
    out = []
    for group in spec.partition(":")[2].split(";"):
        comps = [[float(v) for v in c.split("@")[:2]] for c in group.split(",") if c.strip()]
        out.append([(a, p) for a, p in comps if a > 0])
    return out


def line_violation(spec: str, duration: float) -> np.ndarray:
    """Per axis (4,): ``max(MIN_CYCLES period / duration, MIN_BINS / (duration min_sep))
    - 1`` over its tones (<= 0: every line is one the diagnosis' line search resolves --
    a Hann periodogram peak at >= 2 cycles, refined within +-1 bin; two lines closer than
    two bins merge into one peak between them, and the instrument built at that
    frequency misses the motion: the 6.7x error of docs/design.md).  -1 for an axis
    without tones."""
    out = np.full(len(AXES), -1.0)
    for k, comps in enumerate(_tones_of(spec)):
        if not comps:
            continue
        f = np.sort([1.0 / p for _, p in comps])
        worst = MIN_CYCLES / (duration * f[0])
        if f.size > 1:
            worst = max(worst, MIN_BINS / (duration * max(float(np.min(np.diff(f))), 1e-300)))
        out[k] = worst - 1.0
    return out


def resolved_tones(spec: str, duration: float) -> dict[int, list[float]]:
    """Tones [Hz] per axis index of a multi-sine spec that a periodogram of ``duration``
    resolves as separate lines: at least two cycles in the run, and, strongest first, at
    least two frequency bins (``2 / duration``) from every stronger kept line (the
    diagnosis' line search merges closer ones into one peak)."""
    out: dict[int, list[float]] = {}
    for k, comps in enumerate(_tones_of(spec)):
        kept: list[float] = []
        for _, period in sorted(comps, reverse=True):
            f = 1 / period
            if MIN_CYCLES * period <= duration and all(abs(f - g) >= MIN_BINS / duration
                                                       for g in kept):  # fmt: skip
                kept.append(f)
        out[k] = sorted(kept)
    return out


def _unchecked_refs(spec: str, duration: float, fs: float) -> np.ndarray:
    """References (4, N) of a multi-sine spec without Eq. 20's checks (the problem scores
    violations as constraints instead of refusing the design)."""
    from tmopt.physics.scenario import _sines  # one implementation of Eq. 17

    t = np.arange(int(round(duration * fs))) / fs
    body = spec.partition(":")[2]
    out = []
    for group in body.split(";"):
        comps = [[float(v) for v in c.split("@")] for c in group.split(",") if c.strip()]
        out.append(_sines(comps, t, fs)[0])
    return np.array(out)
