"""Information of a planned excitation about the stiffness and the suspected effects.

The diagnosis (:mod:`tmopt.mismatch.diagnose`) estimates the nominal parameters and any
effect by generalised least squares on the two f_B-free combinations of Eq. 10
(equation group; ``tmopt.mismatch.fit.solve``) and by instrumental variables on the ZOH
kinematics (kinematic group; ``solve_iv``).  Their covariances depend on the regressors
and on the noise model only, not on the noise draw (Ljung, *System Identification*, 2nd
ed., 1999, Sec. 9.3; for IV with the deterministic part of the regressor as instrument,
``s^2 (Z'X)^-1 Z'Z (X'Z)^-1 -> s^2 (Z'Z)^-1``, Sec. 9.4).  So the standard errors that a
second recording will give are predicted from

* the regressors of the *planned* motion: one noise-free closed-loop run of the design
  with the identified model (``tmopt.physics.information.noise_free``), its columns
  built by the very code of the diagnosis (``nominal_equation_columns`` and each effect's
  :meth:`~tmopt.mismatch.effects.base.Effect.regressors`), and
* the noise level estimated from the recording: the diagnosis' own fitted noise models
  (:class:`~tmopt.mismatch.noise_model.NoiseModel`, a smooth cross-spectrum per group,
  a density in frequency, so it applies to any length), laid out on the planned run's
  segments (:meth:`~tmopt.mismatch.noise_model.NoiseModel.relayout`) and applied by its
  own :meth:`~tmopt.mismatch.noise_model.NoiseModel.whiten` -- the whitening the
  diagnosis will apply to the second recording.

The information matrix of the whitened, extended regression is ``X_w' X_w`` (Fisher
information of a Gaussian linear model with white whitened noise; Fedorov, *Theory of
Optimal Experiments*, 1972).  The predicted covariance is the diagnosis' own formula at
the whitened noise's expected variance ``v(t)`` (:meth:`NoiseModel.whitened_variance`:
the square of each segment's taper, since whitening a tapered segment gives tapered
white noise): ``mean(v) (X_w'X_w)^-1`` for GLS (``fit.solve``: ``s^2 = RSS/(n - p)``),
and ``(Z'X)^-1 Z' diag(v) Z (X'Z)^-1`` for IV (``fit.solve_iv``: White's
heteroscedasticity-consistent form at ``E r^2 = v``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from tmopt.mismatch.effects import EFFECTS, Candidate, Context
from tmopt.mismatch.fit import Column, Data, nominal_equation_columns
from tmopt.mismatch.noise_model import NoiseModel, _floor_psd
from tmopt.physics.recording import AXES

__all__ = ["Target", "Rival", "NoiseLevel", "Prediction", "predict", "candidate_for",
           "rival_candidate"]

NOMINAL = ("k1xx", "k2xx", "k1yy", "k2yy", "R1", "R2")


@dataclass(frozen=True)
class Rival:
    """What an ambiguous name could equally be: a catalogue effect ``effect[channel]`` or,
    with ``feature`` set, an unnamed feature of :mod:`tmopt.mismatch.generic` on
    ``channel`` (``effect`` is then ``generic.GENERIC``)."""

    effect: str
    channel: str
    feature: str | None = None

    @property
    def key(self) -> str:
        return f"{self.feature or self.effect}[{self.channel}]"


@dataclass(frozen=True)
class Target:
    """One effect parameter the diagnosis could not identify: ``effect[channel]``, its
    plausible size (the diagnosis' prior) and why (``not excited`` / ``aliased``); or an
    ambiguous name (``reason`` "ambiguous"): ``plausible`` is then the size the recording
    showed and ``rivals`` the alternatives the prediction profiles (docs/design.md,
    "Ambiguous names")."""

    effect: str
    channel: str
    plausible: float
    reason: str = ""
    aliased_with: str | None = None
    rivals: tuple[Rival, ...] = ()

    @property
    def key(self) -> str:
        return f"{self.effect}[{self.channel}]"


@dataclass
class NoiseLevel:
    """Noise models estimated from the recording (the diagnosis' final state)."""

    equation: NoiseModel
    kinematic: NoiseModel

    def for_data(self, data: Data) -> tuple[NoiseModel, NoiseModel]:
        """Both models on the segments of ``data`` (equation, kinematic layouts)."""
        return self.equation.relayout(data.layout), self.kinematic.relayout(data.kin_layout)


@dataclass
class Prediction:
    """Predicted standard errors ``se`` {parameter or target key: value} and, per target,
    the largest |correlation| of its estimate with a nominal parameter's (or a rival's)
    and that parameter (the aliasing the design should break).  ``selection``: per
    ambiguous equation target, its standard error with its rivals profiled at the
    diagnosis' *selection step*, whose noise model is estimated from the nominal residual
    and so holds the target's own unmodelled signal (:func:`selection_noise`)."""

    se: dict[str, float]
    correlation: dict[str, tuple[float, str]]
    selection: dict[str, float] = field(default_factory=dict)

    def judged(self, key: str) -> float:
        """The standard error the diagnosis judges a target by: at its selection step for
        an ambiguous name (the rivals' delta-BIC band is decided there), else ``se``."""
        return self.selection.get(key, self.se[key])


def candidate_for(target: Target, data: Data, basis: np.ndarray,
                  cache: dict | None = None) -> Candidate:  # fmt: skip
    """The diagnosis' candidate of ``target`` for ``data`` (the same regressors);
    ``cache`` keeps each effect's candidates for further targets on the same data."""
    cache = {} if cache is None else cache
    if target.effect not in cache:
        cache[target.effect] = EFFECTS[target.effect].regressors(data, basis)
    for cand in cache[target.effect]:
        if cand.channel == target.channel:
            return cand
    raise ValueError(f"effect {target.effect!r} has no candidate on channel {target.channel!r}")


def rival_candidate(rival: Rival, data: Data, basis: np.ndarray,
                    cache: dict | None = None) -> Candidate:  # fmt: skip
    """The candidate of ``rival`` for ``data``: a catalogue effect's (as
    :func:`candidate_for`), or an unnamed feature whose regressor the planned motion (or
    the time) fixes -- ``x|x|``, ``x^2``, ``f|f|``, ``x*y``, curvature, a readout timing
    (kinematic: the tone part of the accelerometer term, differentiated) -- built by the
    diagnosis' own code (:mod:`tmopt.mismatch.generic`).  A feature searched on the
    residual (a step at an onset, a line at a frequency, a relaxation) is the recording's
    event, not a column of a planned run: ValueError."""
    if rival.feature is None:
        return candidate_for(Target(rival.effect, rival.channel, 1.0), data, basis, cache)
    from tmopt.mismatch import generic

    cache = {} if cache is None else cache
    if generic.GENERIC not in cache:
        ctx = Context(data, basis)  # these builders read the data only, not a residual
        cache[generic.GENERIC] = (generic._nonlinear(ctx) + generic._products(ctx)
                                  + generic._curvatures(ctx)
                                  + generic._readout_timings(ctx))  # fmt: skip
    for cand in cache[generic.GENERIC]:
        if cand.channel == rival.channel and cand.fixed.get("feature") == rival.feature:
            return cand
    raise ValueError(f"feature {rival.feature!r} on {rival.channel!r} is no column of a "
                     "planned run (a searched event or line of the recording)")


class _Regressors(Data):
    """The data with excitation tones only on the axes that drive a target
    (``_instrumented``), found as the diagnosis finds them (:meth:`Data.tones`: from the
    reference on x, from the readout on y).  The kinematic candidates' instruments (the
    tone part of each regressor, :func:`tmopt.mismatch.fit.tone_instrument`) of the other
    axes are then zeros and cost nothing; they are not used."""

    def tones(self, axis: int) -> list[float]:
        if axis not in self.__dict__.get("_instrumented", ()):
            return []
        known = self.__dict__.get("_known")
        if known is not None:
            return known.get(axis, [])
        return Data.tones(self, axis)


def regressor_data(data: Data, axes: tuple[int, ...] = (),
                   known: dict[int, list[float]] | None = None) -> Data:  # fmt: skip
    """``data`` for the regressors of targets driven by ``axes`` (see :class:`_Regressors`);
    ``known``: the tones [Hz] of a planned run per axis, used instead of searching the
    periodogram (the search's refinement costs ~0.2 s an axis and finds these)."""
    out = _Regressors(**{f.name: getattr(data, f.name) for f in fields(Data)})
    out._instrumented = frozenset(axes)
    out._known = known
    return out


def source_axis(channel: str) -> int:
    """The axis whose motion drives a candidate: ``a<-b`` -> b, ``kind:a`` -> a,
    ``a readout`` -> a."""
    name = channel.split(" ")[0].rpartition(":")[2].rpartition("<-")[2]
    return AXES.index(name) if name in AXES else -1


def _whitened(cols: list[Column], whiten) -> np.ndarray:
    return np.column_stack([whiten(c.values).ravel() for c in cols])


def _inverse(x: np.ndarray) -> np.ndarray:
    """``(X'X)^-1`` of a column-scaled design (pinv: a column the motion leaves at zero
    gets an infinite standard error, set below)."""
    scale = np.sqrt(np.sum(x**2, axis=0))
    dead = scale == 0
    scale[dead] = 1.0
    inv = np.linalg.pinv((x / scale).T @ (x / scale)) / np.outer(scale, scale)
    inv[dead, :] = np.inf
    inv[:, dead] = np.inf
    return inv


def predict(data: Data, basis: np.ndarray, targets: list[Target], noise: NoiseLevel,
            tones: dict[int, list[float]] | None = None) -> Prediction:  # fmt: skip
    """Predicted standard errors of the nominal parameters and of every target for the
    regressors of ``data`` (a recording, or a planned design's noise-free run).

    Equation targets join the nominal columns of Eqs. 12-15 in one GLS design; kinematic
    targets form the kinematic design (the nominal kinematics has no free parameter).
    The rivals of ambiguous targets (:attr:`Target.rivals`) join their group's design
    too, so every target's standard error is the one with its rivals profiled (the Schur
    complement of the information matrix, as "aliased" targets get theirs with the
    nominal parameters profiled).  The twin of an accelerometer effect in the kinematic
    group is left out (a lower bound on its information, so the prediction errs on the
    safe side).  ``tones`` {axis: [Hz]}: the excitation lines of a planned run (default:
    found in ``data`` as the diagnosis finds them).
    """
    channels = [c for t in targets for c in (t.channel, *(r.channel for r in t.rivals))]
    data = regressor_data(data, tuple({source_axis(c) for c in channels} - {-1}), tones)
    eq_cols = nominal_equation_columns(data, basis)
    kin_cols: list[Column] = []
    eq_keys, kin_keys = [], []
    cache: dict = {}
    for t in targets:
        cand = candidate_for(t, data, basis, cache)
        if cand.group == "equation":
            eq_cols += cand.columns
            eq_keys.append((t, len(cand.columns)))
        else:
            kin_cols += cand.columns
            kin_keys.append((t, len(cand.columns)))
    # rivals after the targets (a rival that is itself a target is in already)
    where = {t.key: (g, sum(w for _, w in keys[:i]))
             for g, keys in (("equation", eq_keys), ("kinematic", kin_keys))
             for i, (t, _) in enumerate(keys)}  # fmt: skip
    for r in dict.fromkeys(r for t in targets for r in t.rivals):
        if r.key in where:
            continue
        cand = rival_candidate(r, data, basis, cache)
        if cand.group == "equation":
            where[r.key] = ("equation", len(eq_cols) - len(NOMINAL))
            eq_cols += cand.columns
        else:
            where[r.key] = ("kinematic", len(kin_cols))
            kin_cols += cand.columns
    se: dict[str, float] = {}
    corr: dict[str, tuple[float, str]] = {}
    eq_noise, kin_noise = noise.for_data(data)
    x = _whitened(eq_cols, eq_noise.whiten)
    inv = _inverse(x) * _whitened_mean_variance(eq_noise)
    for j, name in enumerate(NOMINAL):
        se[name] = _sd(inv[j, j])
    j = len(NOMINAL)
    for t, width in eq_keys:
        se[t.key] = _combined(inv[j : j + width, j : j + width])
        c = _corr_row(inv, j)
        k = int(np.argmax(np.abs(c)))
        corr[t.key] = _with_rivals(inv, j, t, where, "equation", len(NOMINAL),
                                   (float(abs(c[k])), NOMINAL[k]))  # fmt: skip
        j += width
    if kin_cols:
        kinv = _iv_covariance(kin_cols, kin_noise)
        j = 0
        for t, width in kin_keys:
            se[t.key] = _combined(kinv[j : j + width, j : j + width])
            corr[t.key] = _with_rivals(kinv, j, t, where, "kinematic", 0, (0.0, ""))
            j += width
    selection = {}
    nominal = eq_cols[: len(NOMINAL)]
    for t, width in eq_keys:
        if not t.rivals:
            continue
        own = candidate_for(t, data, basis, cache).columns
        rivals = [c for r in t.rivals if where[r.key][0] == "equation"
                  for c in rival_candidate(r, data, basis, cache).columns]  # fmt: skip
        noisy = selection_noise(data, nominal, own, t.plausible, noise)
        inv = _inverse(_whitened(nominal + own + rivals, noisy.whiten))
        j = len(NOMINAL)
        selection[t.key] = _combined(inv[j : j + width, j : j + width]
                                     * _whitened_mean_variance(noisy))  # fmt: skip
    return Prediction(se, corr, selection)


#: Seed of the synthetic noise draw of :func:`selection_noise` (one draw for every
#: design: common random numbers, so designs differ by their motion only).
SELECTION_SEED = 0


def selection_noise(data: Data, nominal: list[Column], own: list[Column], size: float,
                    noise: NoiseLevel) -> NoiseModel:  # fmt: skip
    """The equation noise model the diagnosis will estimate at its selection step on the
    planned run: from the nominal fit's residual (:func:`tmopt.mismatch.diagnose._fit_eq`,
    the diagnosis' own estimate, two rounds) of a noise draw of the recording's model
    (:func:`noise_draw`) plus the target's signal at ``size`` (its columns' sum) -- an
    unmodelled effect's lines raise the smooth spectrum there (the cubic of docs/design.md,
    "Ambiguous names": 4.5-7x the final ASD at its harmonics), so the delta-BIC gap to
    its rivals is judged at a higher noise than the final fit's."""
    from tmopt.mismatch.diagnose import _fit_eq

    eq_noise, _ = noise.for_data(data)
    signal = size * sum(c.values for c in own)
    target = noise_draw(eq_noise, data.layout, SELECTION_SEED) + signal
    _, model = _fit_eq(target, nominal, False, data.layout, data.fs, eq_noise.kind)
    return model


def noise_draw(model: NoiseModel, layout, seed: int) -> np.ndarray:
    """One Gaussian draw (C, n) of ``model`` on ``layout``: per segment, white noise
    coloured by the Cholesky factor of ``S(f)`` (the inverse of
    :meth:`NoiseModel.whiten`, whose ``S`` is in per-sample variance units)."""
    rng = np.random.default_rng(seed)
    c = model.channels
    out = np.zeros((c, layout.n))
    for a, b in layout.bounds:
        m = b - a
        f = np.fft.rfftfreq(m, 1 / model.fs)
        chol = np.linalg.cholesky(_floor_psd(model.matrix(f)))
        w = np.fft.rfft(rng.standard_normal((c, m)), axis=1)
        out[:, a:b] = np.fft.irfft(np.einsum("fij,jf->if", chol, w), n=m, axis=1)
    return out


def _with_rivals(cov: np.ndarray, j: int, t: Target, where: dict, group: str, offset: int,
                 best: tuple[float, str]) -> tuple[float, str]:  # fmt: skip
    """The largest |correlation| of the target's estimate (column j of ``cov``) with a
    nominal parameter's (``best``) or with one of its rivals' in the same group (first
    column; at ``offset`` + their position)."""
    for r in t.rivals:
        g, pos = where.get(r.key, (None, 0))
        if g != group:
            continue
        i = offset + pos
        with np.errstate(invalid="ignore", divide="ignore"):
            c = abs(cov[j, i]) / math.sqrt(max(cov[j, j] * cov[i, i], 1e-300))
        if np.isfinite(c) and c > best[0]:
            best = (float(c), r.key)
    return best


def _whitened_mean_variance(noise: NoiseModel) -> float:
    """``E s^2`` of the diagnosis' GLS (``RSS/(n - p)``) when the model holds: the mean
    expected variance of the whitened noise (the fit removes p samples' worth of it)."""
    return float(np.mean(noise.whitened_variance()))


def _iv_covariance(cols: list[Column], noise: NoiseModel) -> np.ndarray:
    """``(Z'X)^-1 Z' diag(v) Z (X'Z)^-1`` of whitened columns X and instruments Z, ``v``
    the whitened noise's expected variance (the diagnosis' ``solve_iv`` with ``r^2`` at
    its expectation): only the tone part of a regressor informs."""
    x = _whitened(cols, noise.whiten)
    z = _whitened([Column(c.name, c.values if c.instrument is None else c.instrument)
                   for c in cols], noise.whiten)  # fmt: skip
    v = np.tile(noise.whitened_variance(), noise.channels)
    sx, sz = np.sqrt(np.sum(x**2, axis=0)), np.sqrt(np.sum(z**2, axis=0))
    dead = (sx == 0) | (sz == 0)
    sx[sx == 0], sz[sz == 0] = 1.0, 1.0
    xs, zs = x / sx, z / sz
    ainv = np.linalg.pinv(zs.T @ xs)
    cov = ainv @ ((zs * v[:, None]).T @ zs) @ ainv.T / np.outer(sx, sx)
    cov[dead, :] = np.inf
    cov[:, dead] = np.inf
    return cov


def _sd(v: float) -> float:
    return math.sqrt(v) if np.isfinite(v) and v > 0 else math.inf


def _combined(block: np.ndarray) -> float:
    """Standard error of one reported parameter: a single column's, or the sum of several
    (as the diagnosis' identifiability check uses for multi-column candidates)."""
    if block.shape[0] == 1:
        return _sd(float(block[0, 0]))
    return _sd(float(np.sum(block)))


def _corr_row(inv: np.ndarray, j: int) -> np.ndarray:
    d = np.diag(inv)[: len(NOMINAL)]
    with np.errstate(invalid="ignore", divide="ignore"):
        c = inv[j, : len(NOMINAL)] / np.sqrt(np.maximum(d * inv[j, j], 1e-300))
    return np.nan_to_num(c, nan=0.0, posinf=0.0, neginf=0.0)
