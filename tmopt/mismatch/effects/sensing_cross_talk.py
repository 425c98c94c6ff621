"""Sensing cross-talk: a readout that also sees another axis (electrode or optical
misalignment, electronic pick-up)."""

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
    kinematic_column,
)


class SensingCrossTalk(Effect):
    """Readout of axis a sees axis b with coefficient c.

    Made: option ``sensor`` = ``disp`` (displacement readout, in the loop:
    ``x_meas,a = r_a + c r_b + N_m``) or ``acc`` (the accelerometer channel after the run:
    ``acc_a + c acc_b``, both as measured); option ``source`` (default the other in-plane
    axis of the same test mass).  Diagnosed: ``x_meas,a = x_a + c x_b`` (displacement,
    checked by the kinematic residual: ``+ c h^2 a_b``) or ``acc_meas,a = acc_a + c acc_b``
    (accelerometer, a term ``c acc_b`` in axis a's equation).
    """

    name = "sensing_cross_talk"
    position = 8
    parameter, unit, limit = "c", "1", 0.1
    options = {"source": None, "sensor": "disp"}
    group = "mixed"
    plausible = 1e-2
    explanation = ("the {kind} readout of {a} also sees {b}: cross-talk coefficient c "
                   "(electrode or optical misalignment, electronic pick-up)")  # fmt: skip
    # an unexcited source moves with its own noise: seen through least squares (base.
    # UNEXCITED_SOURCE_OLS), at a strength set by that noise motion, not by a design
    needs = ("motion of the source axis (excitation; unexcited, only its noise motion "
             "carries the term)")  # fmt: skip
    calibration = Calibration("y1", {"source": "x1", "sensor": "disp"}, 0.0032, 5.0, 0.034,
                              52.8, "kin_y1")  # fmt: skip

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        src = self.source(ch, opt)
        sensor = self.choice("sensor", opt["sensor"], ("disp", "acc"))
        a, s, c = AXES.index(ch), AXES.index(src), inj.magnitude
        if sensor == "disp":
            b.const("readout", np.eye(4))[a, s] += c
        else:
            b.post.append(lambda chans: _mix(chans, f"acc_{ch}", f"acc_{src}", c))
        return {"c": c, "source": src, "sensor": sensor,
                "tool_channel": f"{sensor}:{ch}<-{src}"}  # fmt: skip

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        d = ctx.data
        for a in range(4):
            for b in range(4):
                if a == b:
                    continue
                ch = f"{AXES[a]}<-{AXES[b]}"
                c = self.equation_candidate(f"acc:{ch}", "c", "1", d.acc[b], ctx, a,
                                            self.plausible)  # fmt: skip
                c.text = self.explanation.format(kind="acceleration", a=AXES[a], b=AXES[b])
                # an accelerometer error also breaks the kinematics: D_a = -c h^2 acc_b
                c.twin = kinematic_column(f"{c.key}:kin", ctx, a, b, -1.0)
                out.append(c)
                disp = self.kinematic_candidate(
                    f"disp:{ch}", "c", ctx, a, b,
                    self.explanation.format(kind="displacement", a=AXES[a], b=AXES[b]))
                disp.eq_tie = _stiffness_on_true_position(ctx, a, b)
                out.append(disp)
        return out


def _stiffness_on_true_position(ctx: Context, a: int, b: int):
    """A displacement cross-talk's place in Eq. 10: the stiffness acts on the true
    position ``x_a = x_meas,a - c x_b``, not the measured one
    (:func:`tmopt.mismatch.diagnose._position_shift`)."""
    xb = ctx.data.x_eq[b]
    return lambda c: (a, -c * xb)


def _mix(chans: dict[str, np.ndarray], to: str, frm: str, c: float) -> None:
    # uses the channel as recorded, before this effect: one consistent order of post-steps
    chans[to] = chans[to] + c * chans[frm]
