"""Readout scale error: a displacement or acceleration readout scaled by ``(1 + e)`` (a
calibration error)."""

from __future__ import annotations

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
    kinematic_column,
)


class ReadoutScale(Effect):
    """Readout calibration error ``(1 + e)``.

    Made: option ``sensor`` = ``disp`` (displacement readout, in the loop:
    ``x_meas = (1 + e) r + N_m``; invisible in Eq. 10, where it is aliased with k) or
    ``acc`` (the accelerometer channel, ``(1 + e) acc`` as measured).  Diagnosed:
    displacement readout (kinematic residual ``+ e h^2 a``; in Eqs. 10-15 it is exactly
    aliased with k) or accelerometer (``+ e acc_a`` in the equation; told apart from a
    gain by its f_B content).
    """

    name = "readout_scale"
    position = 9
    parameter, unit, limit = "e", "1", 0.1
    options = {"sensor": "disp"}
    group = "mixed"
    plausible = 1e-2
    explanation = "the {kind} readout of {a} ({where}) is scaled by (1+e): a calibration error"
    needs = "motion on this axis (displacement scale: any excitation; it is invisible in Eq. 10)"
    calibration = Calibration("x1", {"sensor": "disp"}, 1.3e-05, 4.8, 0.00014, 51.8, "kin_x1")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        sensor = self.choice("sensor", opt["sensor"], ("disp", "acc"))
        a, e = AXES.index(ch), inj.magnitude
        if sensor == "disp":
            b.const("readout", np.eye(4))[a, a] += e
        else:
            b.post.append(lambda chans: chans.__setitem__(f"acc_{ch}",
                                                          (1 + e) * chans[f"acc_{ch}"]))
        return {"e": e, "sensor": sensor, "tool_channel": f"{sensor}:{ch}"}

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        d = ctx.data
        for i, a in enumerate(AXES):
            c = self.equation_candidate(f"acc:{a}", "e", "1", d.acc[i], ctx, i, self.plausible)
            c.derived = {"e": ("ratio", None)}  # regressor is the *scaled* measured acc
            c.text = self.explanation.format(kind="acceleration", a=a, where=TMS[a])
            c.twin = kinematic_column(f"{c.key}:kin", ctx, i, i, -1.0)  # D_a = -e h^2 acc_a
            out.append(c)
            out.append(self.kinematic_candidate(
                f"disp:{a}", "e", ctx, i, i,
                self.explanation.format(kind="displacement", a=a, where=TMS[a])))
        return out
