"""Rotation coupling: Euler and centrifugal accelerations from spacecraft rotation (the
terms of Eq. 1 that Eq. 3 neglects), at test masses off the centre of mass."""

from __future__ import annotations

from typing import Any

import numpy as np

from tmopt.mismatch.effects.base import Builder, Calibration, Candidate, Context, Effect, Injection
from tmopt.mismatch.fit import Column, Data


class RotationCoupling(Effect):
    """Spacecraft rotation seen at the test masses through their lever arms.

    Made: Eq. 1's ``rho x w' + 2 rho' x w + w x (rho x w)`` at each TM (lever arms of the
    0.4 m layout), with the rate and angular acceleration written to the ``sc_omega*``
    witness channels (exact, frame s).  ``channel`` = body axis of the rotation
    (``omega_x|y|z``); magnitude = peak rate [rad s^-1].  Profiles (option ``profile``):
    ``slew`` -- ``w = W sin^2(pi (t - onset)/D)`` over [onset, onset + D] (defaults
    onset = T/4, D = T/2), a smooth attitude manoeuvre; ``jitter`` -- a sum of 24
    random-phase tones log-spaced in [2/T, 0.05 Hz] with equal rate amplitudes, scaled to
    peak ``W`` (slow attitude jitter); w' is the exact derivative in both.

    Diagnosed: driven by the ``sc_omega*`` witnesses (:func:`rotation_series`); parameters:
    the in-plane TM1->TM2 lever arm ``r12`` (frame s), expected near the nominal
    (-separation, 0).
    """

    name = "rotation_coupling"
    position = 7
    parameter, unit, limit = "omega_peak", "rad s^-1", 1e-4
    windowed = True
    channels = ("omega_x", "omega_y", "omega_z")
    default_channel = "omega_z"
    options = {"profile": "slew"}
    plausible = 1.0
    explanation = ("spacecraft rotation (rate and angular acceleration from the attitude "
                   "witnesses) produces Euler and centrifugal accelerations at the test "
                   "masses, which sit off the centre of mass (lever arm r12)")  # fmt: skip
    needs = "spacecraft attitude motion and the six sc_omega* witness channels"
    witness_driven = True  # the sc_omega* channels drive its columns
    calibration = Calibration("omega_z", {"profile": "slew"}, 8.6e-11, 5.0, 9e-10, 51.9, "eq")

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        j = "xyz".index(ch[-1])
        profile = self.choice("profile", opt["profile"], ("slew", "jitter"))
        if profile == "slew":
            t0, t1 = self.window(inj, b, onset=b.duration / 4, length=b.duration / 2)
            t1 = min(t1, b.duration)
            if t1 - t0 <= 0:
                raise ValueError(f"{self.name}: the slew window must end after its onset")
            w, wd = _slew(b.time, t0, t1, inj.magnitude)
            window = {"onset_s": t0, "end_s": t1}
        else:
            if inj.onset is not None or inj.duration is not None:
                raise ValueError(f"{self.name}: the jitter profile lasts the whole run "
                                 "(no onset/duration)")  # fmt: skip
            w, wd = _jitter(b.time, inj.magnitude, b.seed, j)
            window = {}
        b.series("omega", 3)[j] += w
        b.series("omega_dot", 3)[j] += wd
        geo = b.geometry
        return {"omega_peak": inj.magnitude, "axis": ch[-1], "profile": profile,
                "r01_s": geo.r01_s.tolist(), "r02_s": geo.r02_s.tolist(),
                "r12_s": geo.r12_s.tolist(), "tool_channel": "TM1-TM2", **window}  # fmt: skip

    def untestable(self, ctx: Context) -> str | None:
        if ctx.data.omega is None:
            return "the recording has no sc_omega_* / sc_omega_dot_* witness channels"
        return None

    def candidates(self, ctx: Context) -> list[Candidate]:
        if ctx.data.omega is None:
            return []
        s = rotation_series(ctx.data)
        cols = [Column(f"r12_{c}", ctx.basis.T @ s[j]) for j, c in enumerate("xy")]
        return [Candidate(self.name, "TM1-TM2", "equation", ["r12_x", "r12_y"], ["m", "m"],
                          cols, self.plausible, text=self.explanation)]  # fmt: skip


def _slew(t: np.ndarray, t0: float, t1: float, peak: float) -> tuple[np.ndarray, np.ndarray]:
    d = t1 - t0
    inside = (t >= t0) & (t <= t1)
    ph = np.pi * (t - t0) / d
    w = np.where(inside, peak * np.sin(ph) ** 2, 0.0)
    wd = np.where(inside, peak * np.pi / d * np.sin(2 * ph), 0.0)
    return w, wd


def _jitter(t: np.ndarray, peak: float, seed: int, axis: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x0A771, axis]))
    duration = t[-1] + (t[1] - t[0])
    f = np.geomspace(2.0 / duration, 0.05, 24)
    phase = rng.uniform(0, 2 * np.pi, f.size)
    arg = 2 * np.pi * f[:, None] * t[None, :] + phase[:, None]
    w = np.sin(arg).sum(axis=0)
    wd = (2 * np.pi * f[:, None] * np.cos(arg)).sum(axis=0)
    scale = peak / max(np.abs(w).max(), 1e-300)
    return w * scale, wd * scale


def rotation_series(data: Data) -> np.ndarray:
    """Per-axis apparent acceleration (2 components of r12, 4 axes, N) from Eq. 1's terms.

    TM i at ``r0i`` (frame s) feels ``r0i x w' + w x (r0i x w) = -w' x r0i - w x (w x r0i)``
    (Eqs. 1-4; Coriolis ``2 r' x w`` neglected: TM speeds ~1e-6 m/s).  In-plane, for
    ``r = (rx, ry, 0)``: ``A r`` with ``A = [[|w|^2 - wx^2, w'z - wx wy],
    [-w'z - wx wy, |w|^2 - wy^2]]``.  With ``r01 = c - r12/2``, ``r02 = c + r12/2`` the
    common part ``c`` acts like f_B and cancels, leaving a term linear in ``r12``.
    """
    wx, wy, wz = data.omega
    dz = data.omega_dot[2]
    w2 = wx**2 + wy**2 + wz**2
    a = np.array([[w2 - wx**2, dz - wx * wy], [-dz - wx * wy, w2 - wy**2]])  # (2, 2, N)
    wa, wb = data.geometry.w_sa[:2, :2], data.geometry.w_sb[:2, :2]
    out = np.zeros((2, 4, data.n))
    for j in range(2):
        g = a[:, j]  # A e_j, (2, N)
        tm1, tm2 = wa @ (-0.5 * g), wb @ (0.5 * g)
        out[j] = [tm1[0], tm2[0], tm1[1], tm2[1]]
    return out
