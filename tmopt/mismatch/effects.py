"""The catalogue of candidate physical effects: one small class per effect.

Each effect turns a recording into one or more :class:`Candidate` variants (one per test
mass / axis / channel pair): the regressors that the effect adds to the per-axis equation
``acc_a - f_a = k_a x_a + f_D,a - (P f_B)_a + [effect]`` (seen in the two f_B-free
combinations, :func:`tmopt.mismatch.fit.axis_column`), or to the kinematic consistency
residual, with the parameter names, units, the largest physically plausible magnitude (a
prior used only to say whether the excitation can reveal the effect at all) and the words
of the explanation.  Every model term cites its source.  Adding an effect = adding a class
here and listing it in :data:`CATALOGUE`.

Effects whose parameters enter non-linearly (glitch onset/width, quantisation step) search
those parameters on the current residual (profile likelihood) and report a trials factor
(Bonferroni over the search) so that their p-values stay valid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from tmopt.mismatch.fit import (
    AXES,
    Column,
    Data,
    axis_column,
    fb_projection,
    fb_projection_dphi2,
    kinematic_series,
    tone_instrument,
)
from tmopt.mismatch.noise_model import SpatialNoise

__all__ = ["Candidate", "Context", "Effect", "CATALOGUE", "EFFECT_NAMES", "glitch_shape"]

TMS = {"x1": "TM1 sensitive axis", "x2": "TM2 sensitive axis",
       "y1": "TM1 non-sensitive axis", "y2": "TM2 non-sensitive axis"}  # fmt: skip


@dataclass
class Context:
    """What the candidates may look at: the data, the f_B-free basis, current residuals."""

    data: Data
    basis: np.ndarray
    eq_residual: np.ndarray
    eq_noise: SpatialNoise

    @property
    def fb_hat(self) -> np.ndarray:
        """Per-sample least-squares f_B^s (2, N) from the four axes (sign of Eqs. 1-2)."""
        p = fb_projection(self.data.geometry)
        return -np.linalg.pinv(p) @ (self.data.acc - self.data.force)


@dataclass
class Candidate:
    """One variant of an effect: its regressors and how to report it."""

    effect: str
    channel: str
    group: str  # "equation" | "kinematic" | "noise"
    params: list[str]
    units: list[str]
    columns: list[Column] = field(default_factory=list)
    plausible: float | None = None  # largest plausible |parameter| (identifiability prior)
    trials: float = 1.0  # Bonferroni factor of a parameter search (look-elsewhere)
    fixed: dict = field(default_factory=dict)  # searched (profiled) parameters
    derived: dict = field(default_factory=dict)  # how to report a combination of coefs
    text: str = ""
    twin: Column | None = None  # the same parameter's prediction in the kinematic group
    n_searched: int = 0  # parameters found by search (counted in the BIC penalty)

    @property
    def key(self) -> str:
        return f"{self.effect}[{self.channel}]"

    def physical(self, coef: np.ndarray, cov: np.ndarray) -> dict[str, tuple[float, float]]:
        """Fitted coefficients -> reported parameters ``{name: (value, sigma)}``.

        ``derived``: ``("sum", h)`` -- the delay ``tau = h sum c_j`` (FIR group delay);
        ``("ratio", None)`` -- a readout scale fitted on the measured (scaled) channel,
        ``e = b/(1-b)`` (delta method for sigma); otherwise one coefficient per parameter.
        """
        out = {}
        if not self.derived:
            for i, name in enumerate(self.params):
                out[name] = (float(coef[i]), float(math.sqrt(max(cov[i, i], 0.0))))
            return out
        for name, (kind, arg) in self.derived.items():
            if kind == "sum":
                out[name] = (float(arg * coef.sum()), float(arg * math.sqrt(max(cov.sum(), 0))))
            else:
                b, sb = float(coef[0]), math.sqrt(max(cov[0, 0], 0.0))
                out[name] = (b / (1 - b), sb / (1 - b) ** 2)
        return out


class Effect:
    """Base class: ``candidates(ctx)`` -> variants; class attributes document the physics."""

    name: ClassVar[str]
    group: ClassVar[str] = "equation"
    explanation: ClassVar[str]
    needs: ClassVar[str]
    profiled: ClassVar[bool] = False  # parameters searched on the residual (costly)

    def candidates(self, ctx: Context) -> list[Candidate]:
        raise NotImplementedError

    def untestable(self, ctx: Context) -> str | None:
        """Why this recording cannot test the effect at all (e.g. missing channels)."""
        return None


def _eq_candidate(effect: Effect, channel: str, param: str, unit: str, series: np.ndarray,
                  ctx: Context, axis: int, plausible: float) -> Candidate:  # fmt: skip
    col = Column(f"{effect.name}[{channel}]", axis_column(ctx.basis, axis, series))
    text = effect.explanation.format_map(_Blank(ch=channel, where=TMS.get(channel, "")))
    return Candidate(effect.name, channel, "equation", [param], [unit], [col], plausible,
                     text=text)  # fmt: skip


class _Blank(dict):
    """Format mapping that leaves unknown placeholders for the caller to fill."""

    def __missing__(self, key: str) -> str:
        return "{" + key + "}"


def _kin_column(name: str, ctx: Context, a: int, b: int, sign: float = 1.0) -> Column:
    """Kinematic regressor ``sign h^2 (acc_b,n + acc_b,n-1)/2`` on readout channel a, with
    its excitation-tone part as instrument (closed-loop readout noise is in ``acc_b``)."""
    d = ctx.data
    arr = np.zeros((4, d.n - 2))
    inst = np.zeros((4, d.n - 2))
    arr[a] = sign * kinematic_series(d, b)
    inst[a] = tone_instrument(arr[a], d.time[1:-1], d.tones(b))
    return Column(name, arr, inst)


def _kin_candidate(effect: Effect, channel: str, param: str, ctx: Context, a: int, b: int,
                   text: str) -> Candidate:  # fmt: skip
    col = _kin_column(f"{effect.name}[{channel}]", ctx, a, b)
    return Candidate(effect.name, channel, "kinematic", [param], ["1"], [col], 1e-2, text=text)


class ActuationGain(Effect):
    """Applied force ``(1 + g) f`` (electrode gain error; LPF calibrates it with
    multi-frequency force injections, Armano et al. PRD 96, 062004 (2017)).  Term ``g f_a``."""

    name = "actuation_gain"
    explanation = ("the electrostatic actuator on {ch} ({where}) applies (1+g) times the "
                   "commanded force: a gain error of the electrode drive")  # fmt: skip
    needs = ("two or more excitation frequencies (a gain error grows like w^2 relative to "
             "stiffness, which is flat) or broadband force content")  # fmt: skip

    def candidates(self, ctx: Context) -> list[Candidate]:
        return [_eq_candidate(self, a, "g", "1", ctx.data.force[i], ctx, i, 0.05)
                for i, a in enumerate(AXES)]  # fmt: skip


class ActuationDelay(Effect):
    """Applied force ``f(t - tau)`` (electronics latency).  For the sampled force,
    ``f(t - tau) - f(t) = sum_j c_j (f_{n-j} - f_{n-j+1})`` with group delay
    ``tau = h sum_j c_j`` (an FIR delay with unit DC gain); 1 tap is the first-order
    ``-tau f'`` (Taylor), 3 taps reach ~3 samples.  Per tone: residual/motion ~ i w^3 tau."""

    name = "actuation_delay"
    explanation = ("the force on {ch} ({where}) is applied a time tau after it is "
                   "commanded (actuation latency): the residual is the commanded force's "
                   "change over tau")  # fmt: skip
    needs = ("a higher excitation frequency (a delay's residual grows like w^3, in "
             "quadrature with the motion) or broadband force content")  # fmt: skip

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        h = ctx.data.dt
        for i, a in enumerate(AXES):
            f = ctx.data.force[i]
            for taps in (1, 3):
                cols = []
                for j in range(1, taps + 1):
                    d = np.zeros_like(f)
                    d[j:] = f[:-j] - f[1 : f.size - j + 1]  # f_{n-j} - f_{n-j+1}
                    cols.append(Column(f"{self.name}[{a}]c{j}", axis_column(ctx.basis, i, d)))
                out.append(Candidate(
                    self.name, a, "equation", ["tau"], ["s"], cols, 0.2,
                    derived={"tau": ("sum", h)},
                    text=self.explanation.format(ch=a, where=TMS[a]),
                ))  # fmt: skip
        return out


class StiffnessCrossCoupling(Effect):
    """Off-diagonal stiffness of one TM (Eq. 2 keeps only the diagonal): ``k_ab r_b`` in
    axis a's equation, for (x, y) of the same test mass."""

    name = "stiffness_cross_coupling"
    explanation = ("the force gradient of {ch} has an off-diagonal part: motion along the "
                   "other in-plane axis of the same test mass pushes along {ch}")  # fmt: skip
    needs = "motion of the coupling (source) axis: excite that axis"
    PAIRS: ClassVar[tuple[tuple[int, int], ...]] = ((0, 2), (2, 0), (1, 3), (3, 1))

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        for a, b in self.PAIRS:
            ch = f"{AXES[a]}<-{AXES[b]}"
            c = _eq_candidate(self, ch, f"k_{AXES[a]}{AXES[b]}", "s^-2", ctx.data.x[b], ctx, a,
                              1e-6)  # fmt: skip
            c.text = self.explanation.format(ch=AXES[a])
            out.append(c)
        return out


class CubicStiffness(Effect):
    """Non-linear force gradient: ``k3 x_a^3`` (odd term of the force's Taylor series
    about the nominal position; symmetric electrode housing has no even term).  A tone of
    amplitude A gives a line at 3w (harmonic) and a 3/4 k3 A^2 share of apparent stiffness."""

    name = "cubic_stiffness"
    explanation = ("the force on {ch} ({where}) is not linear in the displacement: a cubic "
                   "term k3 x^3 (non-linear electrostatic/gravitational gradient)")  # fmt: skip
    needs = "a larger excitation amplitude on this axis (the term grows like A^3)"

    def candidates(self, ctx: Context) -> list[Candidate]:
        return [_eq_candidate(self, a, "k3", "m^-2 s^-2", ctx.data.x[i] ** 3, ctx, i, 1e3)
                for i, a in enumerate(AXES)]  # fmt: skip


class StiffnessDrift(Effect):
    """Stiffness changing linearly in time (Sec. 1: "possible long-term drift"):
    ``k(t) = k + kdot (t - t_0)``, term ``kdot (t - t_0) x_a``: the identified ``k`` is
    then the stiffness at the start of the record."""

    name = "stiffness_drift"
    explanation = ("the stiffness of {ch} ({where}) drifts linearly during the run "
                   "(e.g. thermal or charge changes of the electrostatic stiffness)")  # fmt: skip
    needs = "a longer run with the excitation kept on throughout"

    def candidates(self, ctx: Context) -> list[Candidate]:
        t = ctx.data.time - ctx.data.time[0]
        span = max(float(t[-1]), ctx.data.dt)
        return [_eq_candidate(self, a, "kdot", "s^-3", t * ctx.data.x[i], ctx, i, 1e-7 / span)
                for i, a in enumerate(AXES)]  # fmt: skip


class BiasDrift(Effect):
    """Bias disturbance f_D changing linearly in time ("very slowly changing", Eq. 2):
    term ``fdot (t - t_0)`` (the bias terms then hold f_D at the start of the record).
    Only its f_B-free part is visible (a common drift is f_B)."""

    name = "bias_drift"
    explanation = ("the bias force on {ch} ({where}) drifts linearly during the run "
                   "(thermal gradients, charging, outgassing)")  # fmt: skip
    needs = "a longer run (the drift's signature grows with the duration squared)"

    def candidates(self, ctx: Context) -> list[Candidate]:
        t = ctx.data.time - ctx.data.time[0]
        span = max(float(t[-1]), ctx.data.dt)
        return [_eq_candidate(self, a, "fdot", "m s^-3", t, ctx, i, 1e-10 / span)
                for i, a in enumerate(AXES)]  # fmt: skip


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


class RotationCoupling(Effect):
    """Euler and centrifugal accelerations from spacecraft rotation (Eq. 3's neglected
    terms), driven by the ``sc_omega*`` witnesses; parameters: the in-plane TM1->TM2 lever
    arm ``r12`` (frame s), expected near the nominal (-separation, 0)."""

    name = "rotation_coupling"
    explanation = ("spacecraft rotation (rate and angular acceleration from the attitude "
                   "witnesses) produces Euler and centrifugal accelerations at the test "
                   "masses, which sit off the centre of mass (lever arm r12)")  # fmt: skip
    needs = "spacecraft attitude motion and the six sc_omega* witness channels"

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
                          cols, 1.0, text=self.explanation)]  # fmt: skip


class SensingCrossTalk(Effect):
    """A readout that also sees another axis: ``x_meas,a = x_a + c x_b`` (displacement,
    checked by the kinematic residual: ``+ c h^2 a_b``) or ``acc_meas,a = acc_a + c acc_b``
    (accelerometer, a term ``c acc_b`` in axis a's equation)."""

    name = "sensing_cross_talk"
    group = "mixed"
    explanation = ("the {kind} readout of {a} also sees {b}: cross-talk coefficient c "
                   "(electrode or optical misalignment, electronic pick-up)")  # fmt: skip
    needs = "motion of the source axis (cross-talk from an unexcited axis is invisible)"

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        d = ctx.data
        for a in range(4):
            for b in range(4):
                if a == b:
                    continue
                ch = f"{AXES[a]}<-{AXES[b]}"
                c = _eq_candidate(self, f"acc:{ch}", "c", "1", d.acc[b], ctx, a, 1e-2)
                c.text = self.explanation.format(kind="acceleration", a=AXES[a], b=AXES[b])
                # an accelerometer error also breaks the kinematics: D_a = -c h^2 acc_b
                c.twin = _kin_column(f"{c.key}:kin", ctx, a, b, -1.0)
                out.append(c)
                out.append(_kin_candidate(
                    self, f"disp:{ch}", "c", ctx, a, b,
                    self.explanation.format(kind="displacement", a=AXES[a], b=AXES[b])))
        return out


class ReadoutScale(Effect):
    """Readout scale factor ``(1 + e)``: displacement readout (kinematic residual
    ``+ e h^2 a``; in Eqs. 10-15 it is exactly aliased with k) or accelerometer
    (``+ e acc_a`` in the equation; told apart from a gain by its f_B content)."""

    name = "readout_scale"
    group = "mixed"
    explanation = "the {kind} readout of {a} ({where}) is scaled by (1+e): a calibration error"
    needs = "motion on this axis (displacement scale: any excitation; it is invisible in Eq. 10)"

    def candidates(self, ctx: Context) -> list[Candidate]:
        out = []
        d = ctx.data
        for i, a in enumerate(AXES):
            c = _eq_candidate(self, f"acc:{a}", "e", "1", d.acc[i], ctx, i, 1e-2)
            c.derived = {"e": ("ratio", None)}  # regressor is the *scaled* measured acc
            c.text = self.explanation.format(kind="acceleration", a=a, where=TMS[a])
            c.twin = _kin_column(f"{c.key}:kin", ctx, i, i, -1.0)  # D_a = -e h^2 acc_a
            out.append(c)
            out.append(_kin_candidate(
                self, f"disp:{a}", "e", ctx, i, i,
                self.explanation.format(kind="displacement", a=a, where=TMS[a])))
        return out


class GeometryError(Effect):
    """True breathing angle off the nominal: the nominal K no longer cancels f_B (Eq. 9).
    First order in ``d_alpha``: residual ``-d_alpha (dP/dphi2) f_B`` with f_B estimated per
    sample; a *common* rotation of both arms is a gauge (f_B is unknown), so only
    ``d_alpha = d_phi2 - d_phi1`` is observable."""

    name = "geometry_error"
    explanation = ("the breathing angle alpha (angle between the arms) differs from the "
                   "nominal: the f_B-cancelling combination of Eq. 9 leaks spacecraft "
                   "acceleration")  # fmt: skip
    needs = "spacecraft acceleration (f_B) variations along both in-plane axes"

    def candidates(self, ctx: Context) -> list[Candidate]:
        dp = fb_projection_dphi2(ctx.data.geometry)
        col = Column("d_alpha", ctx.basis.T @ (-dp @ ctx.fb_hat))
        return [Candidate(self.name, "alpha", "equation", ["d_alpha"], ["rad"], [col], 1e-2,
                          text=self.explanation)]  # fmt: skip


def glitch_shape(t: np.ndarray, beta: float, kind: str) -> np.ndarray:
    """Unit-area force-glitch templates of LISA Pathfinder (Baghi et al., PRD 105, 042002,
    2022): one-sided exponential ``e^{-t/b}/b`` and the n=1 shapelet ``t e^{-t/b}/b^2``
    (t >= 0; zero before the onset).  The amplitude is the velocity kick [m/s]."""
    s = np.where(t >= 0, t, 0.0) / beta
    if kind == "exp":
        return np.where(t >= 0, np.exp(-s), 0.0) / beta
    return s * np.exp(-s) / beta


class Glitch(Effect):
    """A transient force on one axis (LPF glitches), found by a matched filter over onset,
    width (log grid) and shape in the whitened residual, then fitted as a linear amplitude."""

    name = "glitch"
    explanation = ("a transient force (glitch) hits {ch} ({where}) at t0 = {t0:.1f} s with "
                   "decay time {beta:.3g} s ({kind} shape)")  # fmt: skip
    needs = "nothing: a glitch is separable by its time localisation"
    profiled = True
    KINDS: ClassVar[tuple[str, ...]] = ("exp", "shapelet")

    def widths(self, data: Data) -> np.ndarray:
        top = min(200.0, 0.05 * data.n * data.dt)
        return data.dt * 2.0 ** np.arange(0, 40)[data.dt * 2.0 ** np.arange(0, 40) <= top]

    def candidates(self, ctx: Context) -> list[Candidate]:
        best = self.search(ctx)
        if best is None:
            return []
        lam, axis, t0_idx, beta, kind, trials = best
        t0_idx, beta = self.refine(ctx, axis, t0_idx, beta, kind)
        d = ctx.data
        tt = d.time - d.time[t0_idx]
        shape = glitch_shape(tt, beta, kind)
        col = Column(f"glitch[{AXES[axis]}]", axis_column(ctx.basis, axis, shape))
        t0 = float(d.time[t0_idx])
        return [Candidate(
            self.name, AXES[axis], "equation", ["dv"], ["m s^-1"], [col], None, trials,
            fixed={"t0_s": t0, "decay_s": float(beta), "shape": kind}, n_searched=2,
            text=self.explanation.format(ch=AXES[axis], where=TMS[AXES[axis]], t0=t0,
                                         beta=beta, kind=kind),
        )]  # fmt: skip

    def refine(self, ctx: Context, axis: int, k0: int, beta: float, kind: str):
        """Onset (+-1 s) and width (within the grid's factor 2) maximising the matched-filter
        statistic: the coarse width grid otherwise leaves a residual that looks like a
        second glitch."""
        d = ctx.data
        e = ctx.eq_noise.whiten(ctx.eq_residual)
        span = max(1, int(round(1.0 * d.fs)))
        best = (-1.0, k0, beta)
        for b in beta * 2.0 ** np.linspace(-0.5, 0.5, 11):
            g = glitch_shape(d.time - d.time[0], b, kind)
            t = ctx.eq_noise.whiten(axis_column(ctx.basis, axis, g))
            energy = float(np.sum(t**2))
            for k in range(max(0, k0 - span), min(d.n - 1, k0 + span) + 1):
                tk = np.roll(t, k, axis=1)
                tk[:, :k] = 0.0
                lam = float(np.sum(e * tk)) ** 2 / energy
                if lam > best[0]:
                    best = (lam, k, float(b))
        return best[1], best[2]

    def search(self, ctx: Context):
        """Max over axis, width, shape, onset of the matched-filter statistic
        ``(e.t)^2/|t|^2`` on the whitened residual ``e``, with the template ``t`` (the
        glitch on axis a, seen in both f_B-free combinations) whitened by the same noise
        model, so the statistic is chi^2_1 at every trial under the noise model."""
        d = ctx.data
        noise = ctx.eq_noise
        e = noise.whiten(ctx.eq_residual)
        m = e.shape[1]
        nfft = 1 << int(math.ceil(math.log2(2 * m)))
        ef = np.fft.rfft(e, nfft, axis=1)
        best, trials = None, 0
        for beta in self.widths(d):
            for kind in self.KINDS:
                g = glitch_shape(np.arange(m) * d.dt, beta, kind)
                for a in range(4):
                    t = noise.whiten(axis_column(ctx.basis, a, g))
                    corr = np.fft.irfft(ef * np.conj(np.fft.rfft(t, nfft, axis=1)), nfft,
                                        axis=1)[:, :m].sum(axis=0)  # fmt: skip
                    energy = np.cumsum(np.sum(t**2, axis=0))[::-1]  # cut at the record's end
                    # onsets whose template is mostly cut off by the record's end: skipped
                    lam = np.where(energy >= 0.5 * energy[0], corr**2 / energy[0], 0.0)
                    k = int(np.argmax(lam))
                    trials += m
                    if best is None or lam[k] > best[0]:
                        best = (float(lam[k]), a, k, float(beta), kind)
        return None if best is None else (*best, float(trials))


class ColoredNoise(Effect):
    """The noise is not white: white + power-law red spectrum ``1 + (f_k/f)^gamma`` per
    f_B-free combination (Whittle likelihood), decided by a likelihood-ratio test rather
    than by a regressor."""

    name = "colored_noise"
    group = "noise"
    explanation = ("the residual noise is coloured (its spectrum is not flat): e.g. 1/f "
                   "actuation or accelerometer noise; modelled as white + power-law "
                   "red")  # fmt: skip
    needs = "nothing: a noise-model property, tested on the residual spectrum"
    profiled = True

    def candidates(self, ctx: Context) -> list[Candidate]:
        return [Candidate(self.name, "equation residual", "noise", ["knee_hz", "exponent"],
                          ["Hz", "1"],
                          text=self.explanation)]  # fmt: skip


class ActuationQuantisation(Effect):
    """The applied force is the command rounded to a DAC step q: ``Q(f) - f`` is a
    sawtooth of period q in f (``q saw(f/q)``, whose fundamental is ``sin(2 pi f/q)/pi``).
    q is found as the peak of the residual's Fourier transform over the force values
    (on a fine force grid), then the exact sawtooth (offset profiled) is regressed."""

    name = "actuation_quantisation"
    explanation = ("the applied force is the commanded force rounded to steps of "
                   "q = {q:.3g} m s^-2 (actuator DAC resolution)")  # fmt: skip
    needs = "force commands spanning many steps (any closed-loop run does)"
    profiled = True
    Q_RANGE: ClassVar[tuple[float, float]] = (1e-14, 1e-9)
    MAX_GRID: ClassVar[int] = 1 << 20

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
        return 1.0 / self._refine(ctx, nu[k], nu[1] - nu[0]), float(np.sum(ok))

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


CATALOGUE: tuple[Effect, ...] = (
    ActuationGain(), ActuationDelay(), StiffnessCrossCoupling(), CubicStiffness(),
    StiffnessDrift(), BiasDrift(), RotationCoupling(), SensingCrossTalk(), ReadoutScale(),
    GeometryError(), Glitch(), ColoredNoise(), ActuationQuantisation(),
)  # fmt: skip

EFFECT_NAMES: tuple[str, ...] = tuple(e.name for e in CATALOGUE)
