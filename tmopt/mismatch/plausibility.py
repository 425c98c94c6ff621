"""Is this a closed-loop recording the diagnosis can speak about?  (Issue 20, part 4.)

The diagnosis compares a recording with the model of a closed loop.  Nonsense input --
white noise in every channel, a constant or all-zero channel, shuffled samples, swapped
channels, a few seconds of data -- must not be "explained" by physical effects, nor get a
confident "no significant mismatch".  Before any fit, :func:`precheck` tests the loop's
own consistency, channel by channel, with tests that need no model of the controller or
the noise levels:

* **enough data**: at least :data:`MIN_SAMPLES` samples in gap-free segments (the noise
  model needs Welch pieces and bands; the locate step needs windows);
* **live channels**: no displacement, acceleration or force channel is constant (a dead
  sensor, a filler value, a noise-free simulation: nothing to test against);
* **excitation**: some axis carries excitation lines (the identification needs them;
  shuffled samples have none);
* **force vs acceleration** (Eq. 10): in the f_B-free combinations the measured
  acceleration follows the commanded force with slope 1 (``acc - f = k x + f_D - P f_B +
  noise``); a slope measurably far from 1 (beyond any plausible gain error) means the
  channels do not belong together;
* **displacement vs acceleration** (kinematics): at the excitation tones of an excited
  axis the readout's second difference equals ``h^2`` times the acceleration (slope 1,
  instrumental variables as in the kinematic group);
* **force vs displacement** (causality of the controller): the commanded force of a
  closed loop is a causal function of past readouts; a low-order linear model
  ``f_n ~ f_{n-1}, f_{n-2}, e_n, e_{n-1}, e_{n-2}`` (e = reference - readout) fitted in
  short windows (adaptive gains allowed) explains most of its variance on some axis.  If
  no axis shows this, the data are not a closed loop (or are shuffled).

Each test gives ``ok`` (verified), ``unknown`` (cannot tell: e.g. no motion) or
``fail``; any ``fail``, or no positive evidence of a closed loop at all, refuses the
recording with "cannot diagnose: <why>".  After the fit, :func:`implausible_effects`
refuses explanations whose size is beyond physics (a "readout scale" of 999 is a unit
error, not a calibration error).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tmopt.mismatch.fit import AXES, Data, null_basis, tone_instrument

__all__ = ["MIN_SAMPLES", "Check", "Verdict", "precheck", "implausible_effects"]

#: Fewest samples (in gap-free segments) a diagnosis accepts.
MIN_SAMPLES = 256
#: A slope of acc on force (or of d2x on h^2 acc) further than this from 1 is not a gain
#: or scale error (the catalogue's plausible magnitudes are <= 5 %, its range <= 50 %).
SLOPE_TOLERANCE = 0.5
#: ... and it must be this many standard errors away (a measured, not a noisy, slope).
SLOPE_Z = 6.0
#: A slope known to this standard error verifies the relation.
SLOPE_SE_OK = 0.1
#: Windowed R^2 of the causal controller model: above it the force follows the readouts.
LOOP_R2_OK = 0.5
CONTROLLER_WINDOW = 64


@dataclass
class Check:
    name: str
    status: str  # "ok" | "unknown" | "fail"
    detail: str
    values: dict = field(default_factory=dict)


@dataclass
class Verdict:
    checks: list[Check]
    reason: str | None = None  # None: the recording may be diagnosed

    @property
    def refused(self) -> bool:
        return self.reason is not None

    def as_dict(self) -> dict:
        return {"refused": self.refused, "reason": self.reason,
                "checks": [{"name": c.name, "status": c.status, "detail": c.detail,
                            **({"values": c.values} if c.values else {})}
                           for c in self.checks]}  # fmt: skip


def _slope(y: np.ndarray, x: np.ndarray, z: np.ndarray | None = None) -> tuple[float, float]:
    """IV (or OLS when ``z`` is None) slope of y on x with its standard error."""
    z = x if z is None else z
    zx = float(z @ x)
    if zx == 0 or not math.isfinite(zx):
        return math.nan, math.inf
    b = float(z @ y) / zx
    r = y - b * x
    se = math.sqrt(float(np.mean(r**2)) * float(z @ z)) / abs(zx)
    return b, se


def _demean(v: np.ndarray) -> np.ndarray:
    return v - v.mean(axis=-1, keepdims=True)


def check_length(data: Data) -> Check:
    n = data.n
    if n < MIN_SAMPLES:
        rec = data.usage.get("samples_recorded", n)
        return Check("enough data", "fail",
                     f"only {n} usable samples (of {rec} recorded, in gap-free segments of "
                     f">= 64); the noise model and the tests need at least {MIN_SAMPLES}",
                     {"samples_used": n})  # fmt: skip
    return Check("enough data", "ok", f"{n} samples in {len(data.segments)} segment(s)")


def check_live(data: Data) -> Check:
    dead = []
    for kind, arr in (("", data.x), ("acc_", data.acc), ("force_", data.force)):
        for a, name in enumerate(AXES):
            if arr.shape[1] and float(np.ptp(arr[a])) == 0.0:
                dead.append(f"{kind}{name} = {arr[a, 0]:.3g}")
    if dead:
        return Check("live channels", "fail",
                     f"constant channel(s) {', '.join(dead)}: a dead sensor, a filler value or "
                     "a noise-free simulation leaves nothing to test against")  # fmt: skip
    return Check("live channels", "ok", "every channel varies")


def check_excitation(data: Data) -> Check:
    """At least one axis carries excitation lines (:meth:`Data.tones`: from the recorded
    reference, else the readout).  The identification of Eq. 10 and every kinematic test
    work at the excitation tones (Eq. 20's multi-sine); a record without a line has
    nothing to identify with -- an unexcited record, or samples out of time order (a
    shuffle spreads a line over the whole band)."""
    found = {AXES[a]: data.tones(a) for a in range(4)}
    excited = {k: v for k, v in found.items() if v}
    if not excited:
        return Check("excitation", "fail",
                     "no excitation line on any axis (no periodogram peak >= 1e4 x its "
                     "surroundings in the references or readouts): the identification needs "
                     "an excited motion (Eq. 20); an unexcited record, or samples out of time "
                     "order?")  # fmt: skip
    return Check("excitation", "ok", "excited axes: " + ", ".join(
        f"{k} ({', '.join(f'{t:.4g}' for t in v)} Hz)" for k, v in excited.items()),
        {k: list(v) for k, v in excited.items()})  # fmt: skip


def check_force_acc(data: Data) -> Check:
    """Slope of N'acc on N'force (f_B-free combinations), the stiffness terms N'(k x)
    removed by regression; first differences suppress slow drifts.  The force channels
    are tried at whole-sample lags -2..2 (a timestamp convention, which the diagnosis
    aligns: :func:`tmopt.mismatch.fit.align_force_timing`) and the best-fitting lag is
    judged."""
    basis = null_basis(data.geometry)
    best = None
    for lag in range(-2, 3):
        vals = _force_acc_slopes(data, basis, lag)
        if vals is None:
            continue
        score = sum(v["r2"] for v in vals.values())
        if best is None or score > best[0]:
            best = (score, lag, vals)
    if best is None:
        return Check("force vs acceleration", "unknown", "too few samples")
    _, lag, vals = best
    fails, oks = [], []
    for j, v in enumerate(vals.values()):
        b, se = v["slope"], v["se"]
        if abs(b - 1) > SLOPE_TOLERANCE and abs(b - 1) > SLOPE_Z * se:
            fails.append(f"{b:.3g} +- {se:.2g} in combination {j + 1}")
        elif se < SLOPE_SE_OK and abs(b - 1) <= SLOPE_TOLERANCE:
            oks.append(j)
    vals = {**vals, "force_lag_samples": lag}
    if fails:
        return Check("force vs acceleration", "fail",
                     "the measured accelerations do not follow the commanded forces (slope "
                     f"of acc on force {'; '.join(fails)} in Eq. 10's f_B-free combinations, "
                     f"at the best force timing (lag {lag}); a closed loop gives 1 up to a "
                     "gain error of a few %): unrelated, swapped or rescaled channels?",
                     vals)  # fmt: skip
    if oks:
        return Check("force vs acceleration", "ok", "acc follows force (slope ~1)", vals)
    return Check("force vs acceleration", "unknown",
                 "the forces are too small to verify the relation", vals)  # fmt: skip


def _force_acc_slopes(data: Data, basis: np.ndarray, lag: int) -> dict | None:
    from tmopt.mismatch.fit import _shifted

    d = _shifted(data, lag)
    if d.n < 16:
        return None
    ya, yf = basis.T @ d.acc, basis.T @ d.force
    out = {}
    for j in range(2):
        y = _diff_in_segments(d, ya[j])
        f = _diff_in_segments(d, yf[j])
        xs = np.array([_diff_in_segments(d, basis[a, j] * d.x[a]) for a in range(4)])
        design = np.column_stack([f] + list(xs))
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        res = y - design @ coef
        q, _ = np.linalg.qr(xs.T)
        fp = f - q @ (q.T @ f)
        nn = float(fp @ fp)
        se = math.sqrt(float(np.mean(res**2)) / nn) if nn > 0 else math.inf
        tot = float(np.sum((y - y.mean()) ** 2))
        r2 = 1 - float(res @ res) / tot if tot > 0 else 0.0
        out[f"combination_{j + 1}"] = {"slope": float(coef[0]), "se": se, "r2": r2}
    return out


def _diff_in_segments(data: Data, v: np.ndarray) -> np.ndarray:
    return np.concatenate([np.diff(v[a:b]) for a, b in data.segments])


def check_kinematics(data: Data) -> Check:
    """IV slope of the readout's second difference on ``h^2 (a_n + a_{n-1})/2`` at the
    excitation tones of each axis that has them."""
    n = data.kin_index
    h2 = data.dt**2
    vals, fails, oks = {}, [], []
    for a in range(4):
        tones = data.tones(a)
        if not tones:
            continue
        d2x = data.x[a, n + 1] - 2 * data.x[a, n] + data.x[a, n - 1]
        acc = 0.5 * h2 * (data.acc[a, n] + data.acc[a, n - 1])
        z = tone_instrument(acc, data.time[n], tones)
        b, se = _slope(d2x, acc, z)
        vals[AXES[a]] = {"slope": b, "se": se}
        if not math.isfinite(b):
            continue
        if abs(b - 1) > SLOPE_TOLERANCE and abs(b - 1) > SLOPE_Z * se:
            fails.append(f"{AXES[a]}: {b:.3g} +- {se:.2g}")
        elif se < SLOPE_SE_OK and abs(b - 1) <= SLOPE_TOLERANCE:
            oks.append(a)
    if fails:
        return Check("displacement vs acceleration", "fail",
                     "the displacement readouts are not the double integral of the measured "
                     f"accelerations at the excitation tones (slope {'; '.join(fails)}; "
                     "kinematics gives 1): shuffled, swapped or rescaled channels?",
                     vals)  # fmt: skip
    if oks:
        return Check("displacement vs acceleration", "ok",
                     "readouts and accelerations agree at the excitation tones", vals)
    return Check("displacement vs acceleration", "unknown",
                 "no excited axis to verify the kinematics on", vals)  # fmt: skip


def check_controller(data: Data) -> Check:
    """Median windowed R^2 of ``f_n ~ f_{n-1}, f_{n-2}, e_n, e_{n-1}, e_{n-2}`` per axis."""
    w = CONTROLLER_WINDOW
    vals = {}
    for a in range(4):
        ref = data.ref[a] if data.ref is not None and a < 2 else 0.0
        e = ref - data.x[a]
        f = data.force[a]
        r2s = []
        for s0, s1 in data.segments:
            for k in range(s0 + 2, s1 - w + 1, w):
                sl = slice(k, k + w)
                y = f[sl]
                if float(np.ptp(y)) == 0:
                    continue
                design = np.column_stack([np.ones(w), f[k - 1 : k - 1 + w], f[k - 2 : k - 2 + w],
                                          e[sl], e[k - 1 : k - 1 + w], e[k - 2 : k - 2 + w]])
                coef, *_ = np.linalg.lstsq(design, y, rcond=None)
                res = y - design @ coef
                tot = float(np.sum((y - y.mean()) ** 2))
                if tot > 0:
                    r2s.append(1 - float(res @ res) / tot)
                if len(r2s) >= 200:
                    break
        vals[AXES[a]] = float(np.median(r2s)) if r2s else math.nan
    best = max((v for v in vals.values() if math.isfinite(v)), default=math.nan)
    if math.isfinite(best) and best >= LOOP_R2_OK:
        return Check("force vs displacement", "ok",
                     f"the force follows the readouts through a causal controller (median "
                     f"windowed R^2 up to {best:.3f})", vals)  # fmt: skip
    return Check("force vs displacement", "fail",
                 "the commanded forces do not follow the displacement readouts through any "
                 f"causal controller (median R^2 of a 2nd-order model in {w}-sample windows "
                 f"at most {best:.2f} over the four axes; a closed loop gives > {LOOP_R2_OK}):"
                 " not a closed-loop recording, or its samples are shuffled", vals)


def precheck(data: Data) -> Verdict:
    """The checks of the module docstring, cheapest first; stops at the first refusal."""
    checks: list[Check] = []
    for fn in (check_length, check_live, check_excitation, check_force_acc, check_kinematics,
               check_controller):
        c = fn(data)
        checks.append(c)
        if c.status == "fail":
            return Verdict(checks, f"cannot diagnose: {c.detail}")
    return Verdict(checks)


def implausible_effects(effects: list[dict]) -> str | None:
    """A reason to refuse when a selected explanation is beyond physics: a fitted main
    parameter larger than the effect's range (``Effect.limit``, the generator's and the
    catalogue's physical maximum) -- a unit error or a swapped channel, not that effect."""
    from tmopt.mismatch.effects import EFFECTS

    for e in effects:
        model = EFFECTS.get(e["name"])
        if model is None:
            continue
        value = e["parameters"].get(model.parameter)
        if model.parameter == "d_angle":
            value = e["parameters"].get("d_alpha")
        if isinstance(value, (int, float)) and math.isfinite(value) and \
                abs(value) > model.limit:  # fmt: skip
            return (f"cannot diagnose: the best explanation needs {e['name']} "
                    f"[{e['channel']}] with {model.parameter} = {value:.3g} {model.unit}, "
                    f"beyond its physical range (|{model.parameter}| <= {model.limit:g}): "
                    "a unit error, a swapped or a rescaled channel?")
    return None
