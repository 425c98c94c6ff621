"""Bias drift: the bias disturbance f_D changes linearly in time (it is "very slowly
changing", Eq. 2; thermal gradients, charging, outgassing)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from tmopt.mismatch.effects.base import (
    AXES,
    Builder,
    Calibration,
    Candidate,
    Context,
    Effect,
    Injection,
    finite,
    ramp_average,
)
from tmopt.mismatch.fit import Column


class BiasDrift(Effect):
    """Bias force drifting linearly: ``f_D(t) = f_D + fdot clip(t - onset, 0, duration)``.

    Made: applied as its exact average over each sampling interval.  Diagnosed: the term
    ``fdot (t - t_0)`` (the bias terms then hold f_D at the start of the record); only its
    f_B-free part is visible (a common drift is f_B).  ``plausible`` is the largest
    plausible change of f_D over the record [m s^-2].
    """

    name = "bias_drift"
    position = 6
    parameter, unit, limit, windowed = "fdot", "m s^-3", 1e-11, True
    plausible = 1e-10
    slow_in_time = True
    explanation = ("the bias force on {ch} ({where}) drifts linearly during the run "
                   "(thermal gradients, charging, outgassing)")  # fmt: skip
    needs = "a longer run (the drift's signature grows with the duration squared)"
    calibration = Calibration("x1", {}, 2.8e-16, 5.1, 2.7e-15, 49.2, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        t0, t1 = self.window(inj, b)
        avg = ramp_average(b.time, 1.0 / b.fs, t0, t1)
        b.series("force", 4)[AXES.index(ch)] += inj.magnitude * avg
        return {"fdot": inj.magnitude, "onset_s": t0, "end_s": finite(t1)}

    def candidates(self, ctx: Context) -> list[Candidate]:
        t = ctx.data.time - ctx.data.time[0]
        span = max(float(t[-1]), ctx.data.dt)
        # a ramp lives in the record's lowest bins: its own calibrated null (docs 9.11)
        return [replace(self.equation_candidate(a, "fdot", "m s^-3", t, ctx, i,
                                                self.plausible / span), null="ramp")
                for i, a in enumerate(AXES)]  # fmt: skip

    def shape_check(self, ctx: Context, cand: Candidate) -> list[Column]:
        """Legendre P2 and P3 of the record's time on the drift's axis
        (:meth:`~tmopt.mismatch.effects.base.Effect.curvature_in_time`): a slow
        modulation, a relaxation or any curved bias change needs them (over a record
        shorter than its period a 1e-4 Hz modulation is mostly a ramp; only its curved
        part tells them apart -- when that part is below the noise, the data cannot, and
        the drift name stands)."""
        return self.curvature_in_time(ctx, cand)

    def shape_search(self, ctx: Context, cand: Candidate) -> list[Candidate]:
        """The best step and relaxation of the force on the drift's axis
        (:meth:`~tmopt.mismatch.effects.base.Effect.changes_in_time`): a relaxation that
        starts late passes P2 + P3 as a ramp (benchmark 150000: f150132, docs/mismatch.md
        9.17)."""
        return self.changes_in_time(ctx, cand)
