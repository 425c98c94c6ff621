"""Geometry error: the true arm angles (and so the breathing angle alpha) differ from the
nominal ones written in the recording, so the nominal K no longer cancels f_B (Eq. 9)."""

from __future__ import annotations

from typing import Any

from tmopt.mismatch.effects.base import Builder, Calibration, Candidate, Context, Effect, Injection
from tmopt.mismatch.fit import Column, fb_projection_dphi2
from tmopt.physics.geometry import Geometry


class GeometryError(Effect):
    """True angles off the nominal.

    Made: channel ``alpha`` turns arm 2 (phi2 + d, so alpha + d), ``phi1``/``phi2`` turn
    one arm.  The simulator runs with the true geometry (f_B projections, K of its
    internal RLS); the attributes keep the nominal one.  Diagnosed: first order in
    ``d_alpha``, the residual ``-d_alpha (dP/dphi2) f_B`` with f_B estimated per sample; a
    *common* rotation of both arms is a gauge (f_B is unknown), so only
    ``d_alpha = d_phi2 - d_phi1`` is observable.
    """

    name = "geometry_error"
    position = 10
    parameter, unit, limit = "d_angle", "rad", 0.1
    channels = ("alpha", "phi1", "phi2")
    default_channel = "alpha"
    plausible = 1e-2
    explanation = ("the breathing angle alpha (angle between the arms) differs from the "
                   "nominal: the f_B-cancelling combination of Eq. 9 leaks spacecraft "
                   "acceleration")  # fmt: skip
    needs = "spacecraft acceleration (f_B) variations along both in-plane axes"
    calibration = Calibration("alpha", {}, 0.00063, 5.0, 0.0061, 48.5, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        g, d = b.geometry, inj.magnitude
        d1 = d if ch == "phi1" else 0.0
        d2 = d if ch in ("alpha", "phi2") else 0.0
        b.geometry = Geometry(g.phi1 + d1, g.phi2 + d2, g.separation)
        return {"d_phi1": d1, "d_phi2": d2, "d_alpha": d2 - d1,
                "true_phi1": b.geometry.phi1, "true_phi2": b.geometry.phi2,
                "true_alpha": b.geometry.alpha}  # fmt: skip

    def candidates(self, ctx: Context) -> list[Candidate]:
        dp = fb_projection_dphi2(ctx.data.geometry)
        col = Column("d_alpha", ctx.basis.T @ (-dp @ ctx.fb_hat))
        return [Candidate(self.name, "alpha", "equation", ["d_alpha"], ["rad"], [col],
                          self.plausible, text=self.explanation)]  # fmt: skip
