"""Stiffness drift: the stiffness changes linearly in time (Sec. 1: "possible long-term
drift"; e.g. thermal or charge changes of the electrostatic stiffness)."""

from __future__ import annotations

from typing import Any

import numpy as np

from tmopt.mismatch.effects.base import (
    AXES,
    Builder,
    Calibration,
    Candidate,
    Context,
    Effect,
    Injection,
    finite,
    ramp,
)
from tmopt.mismatch.fit import Column


class StiffnessDrift(Effect):
    """Stiffness drifting linearly: ``k(t) = k + kdot clip(t - onset, 0, duration)``.

    Made: defaults from t = 0 to the end, held at its t_n value over each step like every
    state-dependent perturbation; the stiffness at the record's midpoint is reported too,
    since a fit with ``kdot (t - t_mid)`` absorbs the offset into k.  Diagnosed: the term
    ``kdot (t - t_0) x_a``: the identified ``k`` is then the stiffness at the start of the
    record.  ``plausible`` is the largest plausible change of k over the record [s^-2].
    """

    name = "stiffness_drift"
    position = 5
    parameter, unit, limit, windowed = "kdot", "s^-3", 1e-8, True
    plausible = 1e-7
    slow_in_time = True
    explanation = ("the stiffness of {ch} ({where}) drifts linearly during the run "
                   "(e.g. thermal or charge changes of the electrostatic stiffness)")  # fmt: skip
    needs = "a longer run with the excitation kept on throughout"
    calibration = Calibration("x1", {}, 8.4e-12, 5.1, 8.1e-11, 49.2, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        t0, t1 = self.window(inj, b)
        b.series("stiffness_change", 4)[AXES.index(ch)] += inj.magnitude * ramp(b.time, t0, t1)
        mid = float(inj.magnitude * ramp(np.array([b.time[-1] / 2]), t0, t1)[0])
        return {"kdot": inj.magnitude, "onset_s": t0, "end_s": finite(t1),
                "dk_at_mid": mid}  # fmt: skip

    def candidates(self, ctx: Context) -> list[Candidate]:
        t = ctx.data.time - ctx.data.time[0]
        span = max(float(t[-1]), ctx.data.dt)
        return [self.equation_candidate(a, "kdot", "s^-3", t * ctx.data.x_eq[i], ctx, i,
                                        self.plausible / span)
                for i, a in enumerate(AXES)]  # fmt: skip

    def shape_check(self, ctx: Context, cand: Candidate) -> list[Column]:
        """Legendre P2 and P3 of the record's time times the axis' position
        (:meth:`~tmopt.mismatch.effects.base.Effect.curvature_in_time`): a stiffness that
        steps, relaxes or wanders needs them; a linear drift does not.  Without the check
        a stiffness step passed as a ramp (benchmark 140000: k140129, k140131, docs/
        mismatch.md 9.16)."""
        return self.curvature_in_time(ctx, cand, ctx.data.x_eq[AXES.index(cand.channel)])

    def shape_search(self, ctx: Context, cand: Candidate) -> list[Candidate]:
        """The best stiffness step on the drift's axis
        (:meth:`~tmopt.mismatch.effects.base.Effect.changes_in_time`)."""
        return self.changes_in_time(ctx, cand, stiffness=True)
