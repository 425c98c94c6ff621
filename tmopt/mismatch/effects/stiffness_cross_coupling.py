"""Stiffness cross-coupling: the off-diagonal force gradient of one test mass (Eq. 2 keeps
only the diagonal)."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from tmopt.mismatch.effects.base import (
    AXES,
    Builder,
    Calibration,
    Candidate,
    Context,
    Effect,
    Injection,
)


class StiffnessCrossCoupling(Effect):
    """Off-diagonal stiffness: force ``k_ab r_b`` in the equation of axis a.

    Made: on ``channel`` (a) from axis b (option ``source``, default the other in-plane
    axis of the same test mass).  Under the paper's excitation y is held at zero, so
    ``x<-y`` is nearly invisible while ``y<-x`` is driven by the x motion.  Diagnosed:
    ``k_ab r_b`` in axis a's equation, for (x, y) of the same test mass.
    """

    name = "stiffness_cross_coupling"
    position = 3
    parameter, unit, limit = "k_ab", "s^-2", 1e-5
    options = {"source": None}
    plausible = 1e-6
    explanation = ("the force gradient of {ch} has an off-diagonal part: motion along the "
                   "other in-plane axis of the same test mass pushes along {ch}")  # fmt: skip
    needs = "motion of the coupling (source) axis: excite that axis"
    PAIRS: ClassVar[tuple[tuple[int, int], ...]] = ((0, 2), (2, 0), (1, 3), (3, 1))
    calibration = Calibration("y1", {"source": "x1"}, 2.9e-09, 4.8, 3.1e-08, 51.3, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        src = self.source(ch, opt)
        coupling = b.const("stiffness_coupling", np.zeros((4, 4)))
        coupling[AXES.index(ch), AXES.index(src)] += inj.magnitude
        return {f"k_{ch}{src}": inj.magnitude, "source": src, "tool_channel": f"{ch}<-{src}"}

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        for a, b in self.PAIRS:
            ch = f"{AXES[a]}<-{AXES[b]}"
            c = self.equation_candidate(ch, f"k_{AXES[a]}{AXES[b]}", "s^-2", ctx.data.x_eq[b], ctx,
                                        a, self.plausible)  # fmt: skip
            c.text = self.explanation.format(ch=AXES[a])
            c.source_axis = b
            out.append(c)
        return out
