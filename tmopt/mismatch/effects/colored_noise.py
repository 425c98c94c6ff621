"""Coloured noise: the residual noise is not white (e.g. 1/f actuation or accelerometer
noise)."""

from __future__ import annotations

import math
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
)


class ColoredNoise(Effect):
    """Extra acceleration noise with a power-law spectrum.

    Made: on one axis with PSD ``A^2 (f_ref/f)^p`` (A = magnitude, the ASD at ``f_ref`` =
    1 mHz; option ``exponent`` p, default 1 (1/f, "pink"); 2 is red), acting on the TM (in
    the dynamics and in the acceleration channel), optionally only in a window.  Its
    random numbers come from their own stream (seed, axis), so the Table 1 noise
    realisation is unchanged.  Diagnosed: white + power-law red spectrum
    ``1 + (f_k/f)^gamma`` per f_B-free combination (Whittle likelihood), decided by a
    likelihood-ratio test rather than by a regressor (group ``noise``).
    """

    name = "colored_noise"
    position = 12
    parameter, unit, limit = "asd", "m s^-2 Hz^-1/2", 1e-8
    signed, windowed = False, True
    options = {"exponent": 1.0, "f_ref": 1e-3}
    group = "noise"
    explanation = ("the residual noise is coloured (its spectrum is not flat): e.g. 1/f "
                   "actuation or accelerometer noise; modelled as white + power-law "
                   "red")  # fmt: skip
    needs = "nothing: a noise-model property, tested on the residual spectrum"
    profiled = True
    calibration = Calibration("x1", {"exponent": 1.0}, 2.3e-12, 5.3, 7.1e-12, 50.1, "eq")
    noise_like = True

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, opt = self.check(inj, b.duration)
        p = self.option("exponent", opt["exponent"], 0.0, 3.0)
        f_ref = self.option("f_ref", opt["f_ref"], 1e-6, b.fs / 2)
        a = AXES.index(ch)
        rng = np.random.default_rng(np.random.SeedSequence([b.seed, 0xC010, a]))
        noise = coloured_noise(b.n, b.fs, inj.magnitude, p, f_ref, rng)
        t0, t1 = self.window(inj, b)
        b.series("force", 4)[a] += noise * ((b.time >= t0) & (b.time < t1))
        return {"asd": inj.magnitude, "f_ref_hz": f_ref, "exponent": p, "onset_s": t0,
                "end_s": finite(t1)}

    def untestable(self, ctx: Context) -> str | None:
        if ctx.eq_noise is not None and ctx.eq_noise.kind == "smoothed":
            return ("the noise model is estimated from the recording itself (a coloured "
                    "spectrum per residual group), so stationary extra noise is part of it; "
                    "compare with a reference recording of the same instrument, or run with "
                    "the white noise model (--noise white) if the instrument is known to be "
                    "white")  # fmt: skip
        return None

    def candidates(self, ctx: Context) -> list[Candidate]:
        if self.untestable(ctx) is not None:
            return []
        return [Candidate(self.name, "equation residual", "noise", ["knee_hz", "exponent"],
                          ["Hz", "1"],
                          text=self.explanation)]  # fmt: skip


def coloured_noise(n: int, fs: float, asd_ref: float, exponent: float, f_ref: float,
                   rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """Gaussian noise with one-sided PSD ``S(f) = asd_ref^2 (f_ref / max(f, f_min))^p``.

    ``f_min = fs / n`` (flat below the lowest resolved frequency, so the variance is
    finite).  Frequency-domain synthesis: ``X_k = sqrt(S_k fs n / 2) (a + i b)/sqrt(2)``
    with a, b standard normal, then ``x = irfft(X)`` (numpy's 1/n convention), which gives
    ``sum_k S_k df`` as the variance; the DC bin is zero.
    """
    f = np.fft.rfftfreq(n, 1.0 / fs)
    f_min = fs / n
    psd = asd_ref**2 * (f_ref / np.maximum(f, f_min)) ** exponent
    spec = np.sqrt(psd * fs * n / 2) * (rng.standard_normal(f.size)
                                        + 1j * rng.standard_normal(f.size)) / math.sqrt(2)
    spec[0] = 0.0
    if n % 2 == 0:  # the Nyquist bin of a real series is real: keep its expected power
        spec[-1] = math.sqrt(psd[-1] * fs * n / 2) * rng.standard_normal()
    return np.fft.irfft(spec, n)
