"""Actuation quantisation: the applied force is the command rounded to a DAC step q."""

from __future__ import annotations

import math
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
from tmopt.mismatch.fit import Column, axis_column


class ActuationQuantisation(Effect):
    """DAC resolution: the applied force is the command rounded to a step q.

    Made: ``q floor(f/q + 1/2)`` (round half up) of the (delayed) command, before any gain
    error; channel ``all`` quantises all four axes.  Diagnosed: ``Q(f) - f`` is a sawtooth
    of period q in f (``q saw(f/q)``, whose fundamental is ``sin(2 pi f/q)/pi``); q is
    found as the peak of the residual's Fourier transform over the force values (on a
    fine force grid), then the exact sawtooth (offset profiled) is regressed.
    """

    name = "actuation_quantisation"
    position = 13
    parameter, unit, limit = "q", "m s^-2", 1e-8
    signed = False
    channels = AXES + ("all",)
    #: The sawtooth's amplitude per axis is the DAC step's own: 1, up to the drive's gain
    #: error (|g| <= actuation_gain's limit, 0.5).  On the 28 quantisation names of the
    #: nineteenth benchmark run |beta| <= 1.014; a force channel in the wrong unit (x 1e-3)
    #: was "explained" by a sawtooth that is the force itself, beta = -999 (docs 9.19).
    side_limits: ClassVar[dict[str, float]] = {"beta_": 1.5}
    explanation = ("the applied force is the commanded force rounded to steps of "
                   "q = {q:.3g} m s^-2 (actuator DAC resolution)")  # fmt: skip
    needs = "force commands spanning many steps (any closed-loop run does)"
    profiled = True
    #: Searched DAC steps: up to the effect's own limit (a recording scaled to a given SNR in
    #: loud noise needs q ~ 1e-9 and above).
    Q_RANGE: ClassVar[tuple[float, float]] = (1e-14, 1e-8)
    MAX_GRID: ClassVar[int] = 1 << 20
    calibration = Calibration("x1", {}, 2.7e-12, 5.2, 8.4e-12, 50.6, "eq")
    noise_like = True

    def inject(self, inj: Injection, b: Builder) -> dict[str, Any]:
        ch, _ = self.check(inj, b.duration)
        step = b.const("actuation_step", np.zeros(4))
        for a in range(4) if ch == "all" else [AXES.index(ch)]:
            step[a] = inj.magnitude
        return {"q": inj.magnitude, "rounding": "half up"}

    def candidates(self, ctx: Context) -> list[Candidate]:
        found = self.search(ctx)
        if found is None:
            return []
        q, trials = found
        cols = []
        d = ctx.data
        for i, a in enumerate(AXES):
            f = d.force[i]
            off = self._offset(f, q, ctx, i)
            saw = q * np.round((f - off) / q) + off - f
            cols.append(Column(f"quant[{a}]", axis_column(ctx.basis, i, saw)))
        trials *= 2**4  # rounding or truncation chosen per axis
        return [Candidate(self.name, "all axes", "equation", ["beta_x1", "beta_x2", "beta_y1",
                                                              "beta_y2"], ["1"] * 4, cols,
                          None, trials, fixed={"q": q}, n_searched=1,
                          text=self.explanation.format(q=q))]  # fmt: skip

    def _proj(self, ctx: Context, i: int) -> np.ndarray:
        w = ctx.eq_noise.spatial(ctx.eq_residual)
        v = np.linalg.solve(np.linalg.cholesky(ctx.eq_noise.cov), ctx.basis[i])
        return (v / np.linalg.norm(v)) @ w

    def _offset(self, f: np.ndarray, q: float, ctx: Context, i: int) -> float:
        """Rounding (offset 0) or truncation (offset q/2), whichever matches the residual."""
        s = self._proj(ctx, i)
        offs = np.array([[0.0], [0.5 * q]])
        saw = q * np.round((f[None] - offs) / q) + offs - f[None]
        saw -= saw.mean(axis=1, keepdims=True)
        score = np.abs(saw @ s) / np.maximum(np.sqrt(np.sum(saw**2, axis=1)), 1e-300)
        return float(offs[int(np.argmax(score)), 0])

    def search(self, ctx: Context) -> tuple[float, float] | None:
        """Peak over q of the summed (4 axes) power ``|sum_n s_n exp(-2 pi i f_n/q)|^2``."""
        d = ctx.data
        spans = [float(np.ptp(f)) for f in d.force]
        span = max(spans)
        if span <= 0:
            return None
        qmin = max(self.Q_RANGE[0], 4 * span / self.MAX_GRID)
        du = qmin / 4
        nbin = int(2 ** math.ceil(math.log2(span / du + 2)))
        power = np.zeros(nbin // 2 + 1)
        for i in range(4):
            f = d.force[i]
            if np.ptp(f) <= 0:
                continue
            idx = np.clip(((f - f.min()) / du).astype(np.int64), 0, nbin - 1)
            grid = np.bincount(idx, weights=self._proj(ctx, i), minlength=nbin)
            power += np.abs(np.fft.rfft(grid)) ** 2 / d.n
        nu = np.fft.rfftfreq(nbin, du)  # cycles per (m s^-2)
        ok = (nu >= 1 / self.Q_RANGE[1]) & (nu <= 1 / qmin)
        if not np.any(ok):
            return None
        k = np.flatnonzero(ok)[int(np.argmax(power[ok]))]
        q = self._settle(ctx, 1.0 / self._refine(ctx, nu[k], nu[1] - nu[0]), span)
        # the multiples (x2..x4) and the fine grid are further trials of the same search
        return q, float(np.sum(ok)) * len(self.MULTIPLES)

    #: The transform's peak may be a harmonic k/q of the sawtooth (its fundamental is not
    #: always the strongest line over a few hundred steps): q found, 2q, 3q and 4q compete.
    MULTIPLES: ClassVar[tuple[int, ...]] = (1, 2, 3, 4)

    def _saw_score(self, ctx: Context, q: float, s: list) -> float:
        """Sum over axes of the exact sawtooth's matched statistic ``(saw.s)^2/|saw|^2``
        (rounding or truncation, whichever fits), the whole sawtooth, not its fundamental;
        ``s`` and the sawtooth differenced."""
        total = 0.0
        for i, f in enumerate(ctx.data.force):
            if s[i] is None:
                continue
            best = 0.0
            for off in (0.0, 0.5 * q):
                saw = np.diff(q * np.round((f - off) / q) + off - f)
                nn = float(saw @ saw)
                if nn > 0:
                    best = max(best, float(saw @ s[i]) ** 2 / nn)
            total += best
        return total

    def _settle(self, ctx: Context, q0: float, span: float) -> float:
        """q to the precision the sawtooth needs: with N = span/q steps in the force range a
        relative error e misplaces the outer rounding boundaries by N e steps, and each
        misplaced sample leaves a one-sample spike of size q (read as glitches, and a gain
        beta != 1).  The transform's peak is good to ~1/(20 N); the exact sawtooth's
        statistic is maximised over the multiples, then on grids of 1/(10 N) down to
        1/(10^4 N) around the best (under a steep coloured noise model a single sample
        rounded to the wrong side is a whitened outlier of many sigma)."""
        # first differences of both: a crude pre-whitening (the sawtooth is broadband, the
        # residual's noise red), so the fine grid is decided by the sawtooth, not the drift
        s = [np.diff(self._proj(ctx, i)) if np.ptp(f) > 0 else None
             for i, f in enumerate(ctx.data.force)]  # fmt: skip
        best = (-1.0, q0)
        for m in self.MULTIPLES:
            q = m * q0
            if not self.Q_RANGE[0] <= q <= min(self.Q_RANGE[1], 0.5 * span):
                continue
            for qq in q * (1.0 + np.linspace(-1.0, 1.0, 21) * q / span):
                sc = self._saw_score(ctx, float(qq), s)
                if sc > best[0]:
                    best = (sc, float(qq))
        for width in (0.1, 0.01, 0.001):
            q = best[1]
            for qq in q * (1.0 + np.linspace(-width, width, 21) * q / span):
                sc = self._saw_score(ctx, float(qq), s)
                if sc > best[0]:
                    best = (sc, float(qq))
        return best[1]

    def _refine(self, ctx: Context, nu0: float, dnu: float) -> float:
        """Sub-bin frequency of the peak by direct evaluation (the binned transform's
        resolution leaves the sawtooth's phase drifting across the force range)."""
        grid = nu0 + np.linspace(-0.5, 0.5, 21) * dnu
        power = np.zeros(grid.size)
        for i in range(4):
            f = ctx.data.force[i]
            if np.ptp(f) > 0:
                s = self._proj(ctx, i)
                power += np.abs(np.exp(-2j * math.pi * grid[:, None] * f[None]) @ s) ** 2
        return float(grid[int(np.argmax(power))])
