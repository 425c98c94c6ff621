"""Cubic stiffness: a force non-linear in the displacement (odd term of the force's Taylor
series about the nominal position; a symmetric electrode housing has no even term)."""

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
)


class CubicStiffness(Effect):
    """Non-linear force gradient ``k3 r^3`` on one axis.

    Made: a plausible electrostatic value k/D^2 ~ 6e-3 m^-2 s^-2 is far below what the
    1e-5 m motions reveal, so visible magnitudes are large.  Diagnosed: the term
    ``k3 x_a^3``; a tone of amplitude A gives a line at 3w (harmonic) and a 3/4 k3 A^2
    share of apparent stiffness.
    """

    name = "cubic_stiffness"
    position = 4
    parameter, unit, limit = "k3", "m^-2 s^-2", 1e8
    plausible = 1e3
    explanation = ("the force on {ch} ({where}) is not linear in the displacement: a cubic "
                   "term k3 x^3 (non-linear electrostatic/gravitational gradient)")  # fmt: skip
    needs = "a larger excitation amplitude on this axis (the term grows like A^3)"
    calibration = Calibration("x1", {}, 4.3, 4.9, 45.0, 51.1, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        b.const("cubic_stiffness", np.zeros(4))[AXES.index(ch)] += inj.magnitude
        return {"k3": inj.magnitude}

    def candidates(self, ctx: Context) -> list[Candidate]:
        return [self.equation_candidate(a, "k3", "m^-2 s^-2", ctx.data.x_eq[i] ** 3, ctx, i,
                                        self.plausible) for i, a in enumerate(AXES)]  # fmt: skip
