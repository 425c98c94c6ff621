"""Actuation gain error: the electrode drive applies ``(1 + g)`` times the commanded force.

LISA Pathfinder calibrates it with multi-frequency force injections (Armano et al.,
PRD 96, 062004 (2017)).
"""

from __future__ import annotations

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
)


class ActuationGain(Effect):
    """Applied force ``(1 + g) f_cmd`` on one axis.

    Made: from ``onset`` for ``duration`` (default: the whole run); the commanded force
    channel is unchanged, the acceleration channel sees the applied force.  Diagnosed: the
    term ``g f_a`` in axis a's equation.
    """

    name = "actuation_gain"
    position = 1
    parameter, unit, limit, windowed = "g", "1", 0.5, True
    plausible = 0.05
    explanation = ("the electrostatic actuator on {ch} ({where}) applies (1+g) times the "
                   "commanded force: a gain error of the electrode drive")  # fmt: skip
    needs = ("two or more excitation frequencies (a gain error grows like w^2 relative to "
             "stiffness, which is flat) or broadband force content")  # fmt: skip
    calibration = Calibration("x1", {}, 1.4e-05, 4.9, 0.00015, 52.2, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        t0, t1 = self.window(inj, b)
        gain = b.series("actuation_gain", 4)
        gain[AXES.index(ch)] += inj.magnitude * ((b.time >= t0) & (b.time < t1))
        return {"g": inj.magnitude, "onset_s": t0, "end_s": finite(t1)}

    def candidates(self, ctx: Context) -> list[Candidate]:
        return [self.equation_candidate(a, "g", "1", ctx.data.force[i], ctx, i, self.plausible)
                for i, a in enumerate(AXES)]  # fmt: skip
