"""Actuation latency: the force is applied a time ``tau`` after it is commanded."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from tmopt.mismatch.effects.base import (
    AXES,
    TMS,
    Builder,
    Calibration,
    Candidate,
    Context,
    Effect,
    Injection,
)
from tmopt.mismatch.fit import Column, axis_column, switch_series, tone_instrument


class ActuationDelay(Effect):
    """Applied force ``f(t - tau)`` (electronics latency).

    Made: the command held (ZOH) and delayed by tau; fractional delays are exact (the
    simulator splits the step at ``t_n + (tau mod h)``).  Diagnosed: for the sampled
    force, ``f(t - tau) - f(t) = sum_j c_j (f_{n-j} - f_{n-j+1})`` with group delay
    ``tau = h sum_j c_j`` (an FIR delay with unit DC gain); 1 tap is the first-order
    ``-tau f'`` (Taylor), 3 taps reach ~3 samples.  Per tone: residual/motion ~ i w^3 tau.
    The positions also see *when* in the step the force switched: the kinematic twin
    ``(tau/h)(1 - tau/h) x`` :func:`~tmopt.mismatch.fit.switch_series` (docs/mismatch.md
    9.8), tested jointly with the 1-tap variant; once selected, its coefficient is tied to
    the delay's own (not fitted freely).
    """

    name = "actuation_delay"
    position = 2
    parameter, unit, limit, signed = "tau", "s", 10.0, False
    plausible = 0.2
    explanation = ("the force on {ch} ({where}) is applied a time tau after it is "
                   "commanded (actuation latency): the residual is the commanded force's "
                   "change over tau")  # fmt: skip
    needs = ("a higher excitation frequency (a delay's residual grows like w^3, in "
             "quadrature with the motion) or broadband force content")  # fmt: skip
    calibration = Calibration("x1", {}, 3.1e-05, 4.8, 0.00033, 50.9, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        delay = b.const("actuation_delay", np.zeros(4))
        delay[AXES.index(ch)] += inj.magnitude
        return {"tau": inj.magnitude}

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        h = ctx.data.dt
        for i, a in enumerate(AXES):
            f = ctx.data.force[i]
            for taps in (1, 3):
                cols = []
                for j in range(1, taps + 1):
                    # f_{n-j} - f_{n-j+1}, zero where the lag reaches across a gap
                    d = ctx.data.lagged(f, j) - ctx.data.lagged(f, j - 1)
                    d[ctx.data.lagged(np.ones_like(f), j) == 0] = 0.0
                    cols.append(Column(f"{self.name}[{a}]c{j}", axis_column(ctx.basis, i, d)))
                out.append(Candidate(
                    self.name, a, "equation", ["tau"], ["s"], cols, self.plausible,
                    derived={"tau": ("sum", h)},
                    text=self.explanation.format(ch=a, where=TMS[a]),
                    twin=self._twin(ctx, i), twin_tested=taps == 1,
                    twin_tie=_switch_term(ctx.data, i),
                ))  # fmt: skip
        return out

    def _twin(self, ctx: Context, i: int) -> Column:
        """The kinematic side of the same ``c1 = tau/h``: the force switches ``tau`` into
        each step, which the position sees but the step-mean accelerometer does not
        (:func:`tmopt.mismatch.fit.switch_series`).  Its coefficient is ``c1`` to first
        order in tau/h: tested jointly with the 1-tap variant; the 3-tap variant (delays
        of ~1-3 samples, whose switch falls a whole number of samples later) is tested on
        the equation alone.  Either, once selected, ties the twin's coefficient to its
        own (:func:`_switch_term`).  Instrument: its excitation-tone part (the loop feeds
        readout noise into the force)."""
        d = ctx.data
        arr = np.zeros((4, d.kin_index.size))
        inst = np.zeros_like(arr)
        arr[i] = switch_series(d, i)
        inst[i] = tone_instrument(arr[i], d.time[d.kin_index], d.tones(i))
        return Column(f"{self.name}[{AXES[i]}]:kin", arr, inst, tuple(d.tones(i)), i)


def _switch_term(data, i: int):
    """The twin tied to the delay: ``p = tau/h = sum c_j`` -> the kinematic residual of a
    delay ``tau = m h + s`` (``m`` whole samples, ``0 <= s < h``), ``(s/h)(1 - s/h)`` x
    the switch series ``m`` samples later (exact; docs/mismatch.md 9.8).  Below one
    sample (every ``p < 1``, a negative noise estimate included) ``p (1 - p) S``."""
    base = switch_series(data, i)

    def term(p: float) -> np.ndarray:
        m = int(math.floor(p)) if p >= 1.0 else 0
        s = p - m
        out = np.zeros((4, data.kin_index.size))
        out[i] = s * (1.0 - s) * (base if m == 0 else switch_series(data, i, m))
        return out

    return term
