"""A second, independent simulation of the two-test-mass closed loop (issue 26).

The mismatch tool was developed on recordings of the project's kernel
(:mod:`tmopt.physics._closed_loop`): exact zero-order-hold steps, the paper's incremental
PID / FRBF-PID, white Table 1 noise drawn by :mod:`tmopt.physics.noise`, an accelerometer
that reports ``k r(t_n)`` plus the force held over the step.  A tool tuned to those
choices can fail on data made otherwise.  This module integrates *the same equations*
(Eqs. 1-2 with the rotation terms of Eq. 1, f_B seen through Eqs. 5-7) with none of that
code:

* integrator: classical Runge-Kutta (RK4), one step per sample, split where a delayed
  command switches inside the step (RK4 is exact for the held force and accurate to
  ``(sqrt(|k|) h)^5 ~ 1e-15`` for the stiffness term); or (scenario ``integrator``)
  Euler steps, ``substeps`` per sample, as a hand-written simulator may take them --
  ``symplectic`` or ``explicit``, the recorded acceleration being the one the sample's
  first step used (a delayed command enters as its step mean; docs/mismatch.md 9.26);
* controller: a positional continuous-time PID per axis, ``u = Kp e + Ki int e + Kd de/dt``
  with a first-order derivative filter, discretised by Tustin's rule, conditional
  integration at the +-F_max clip; gains from a loop bandwidth drawn per recording
  (x axes 0.3-1 rad/s, y axes 0.1-0.3 rad/s), not the paper's gains;
* noise: time-domain shaping filters -- the 1/f^gamma readout excess and the red
  acceleration excess as sums of first-order (AR(1)) processes whose corner frequencies
  are log-spaced and whose weights are fitted to the target PSD (Keshner, Proc. IEEE 70,
  212 (1982)), the blue tail as a scaled second difference of white noise; readout noise
  in the loop (the controller sees it);
* accelerometer: by default the *mean* acceleration over ``[t_n, t_{n+1})`` (an
  integrating sensor; scenario ``acc_convention = "held"`` gives the kernel's convention,
  ``"end"`` the stiffness term read at the step's end, ``k r(t_{n+1})``);
* readout: the position at t_n, or (scenario ``readout_sampling = "mean"``) its mean over
  the step that ends at t_n (an integrating sensor; the controller sees the same);
* force channel: the command applied from t_n (``applied``) or the one that acted over
  ``[t_{n-1}, t_n)`` (``previous``, a timestamp convention of another simulator);
* geometry: its own frame rotations from the angles.

What it shares with the project: the effect catalogue's *injections* (the named slots of
:class:`tmopt.mismatch.effects.Builder`, read through the validated
:class:`~tmopt.physics.simulator.Perturbations` container and mapped onto its own
physics) and the excitation references.  Used by
:func:`tmopt.mismatch.realistic.realistic_recording` with ``backend="foreign"``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["run_foreign", "ar_sum_noise", "pid_gains"]

F_MAX = 1e-7
GAP_BOUND = 4e-3


# ----------------------------------------------------------------------------- noise


def ar_sum_noise(n: int, fs: float, gamma: float, f_ref: float, level_psd: float,
                 rng: np.random.Generator, n_poles: int = 12) -> np.ndarray:  # fmt: skip
    """Noise with one-sided PSD ~ ``level_psd (f_ref/f)^gamma`` (0 < gamma <= 2) between
    ``fs / n`` and ``fs / 2``, as a weighted sum of AR(1) processes (Keshner 1982).

    Corner frequencies ``f_j`` log-spaced from ``fs / (4 n)`` to ``fs / 2``; an AR(1)
    with corner f_j has PSD ~ ``1 / (1 + (f/f_j)^2)``; weights ``~ f_j^-gamma`` sum to a
    power law of exponent gamma between the corners; the overall level is matched to the
    target (median ratio on a log grid).
    """
    from scipy.signal import lfilter

    corners = np.geomspace(fs / (4 * n), fs / 2, n_poles)
    weights = corners**-gamma
    f_grid = np.geomspace(fs / n, fs / 4, 64)
    model = (weights[None] / (1.0 + (f_grid[:, None] / corners[None]) ** 2)).sum(axis=1)
    target = level_psd * (f_ref / f_grid) ** gamma
    weights *= float(np.median(target / model))
    out = np.zeros(n)
    for wj, fj in zip(weights, corners):
        a = math.exp(-2 * math.pi * fj / fs)
        # x_n = a x_(n-1) + e_n: one-sided PSD 2 s^2 / (fs |1 - a e^(-iw)|^2), i.e.
        # 2 s^2 / (fs (1 - a)^2) at low f: s sets the low-frequency level wj
        s = math.sqrt(wj * fs / 2) * (1 - a)
        out += lfilter([1.0], [1.0, -a], rng.standard_normal(n) * s)
    return out


def blue_noise(n: int, fs: float, f_hi: float, level_psd: float,
               rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """``level_psd (f/f_hi)^4`` at low f: the second difference of white noise, scaled
    (``|1 - e^{-iw}|^4 = (2 sin(w/2))^4 ~ (2 pi f / fs)^4``)."""
    white = rng.standard_normal(n + 2) * math.sqrt(level_psd * fs / 2)
    d2 = white[2:] - 2 * white[1:-1] + white[:-2]
    return d2 * (fs / (2 * math.pi * f_hi)) ** 2


# --------------------------------------------------------------------------- control


def pid_gains(omega_c: float) -> tuple[float, float, float, float]:
    """(Kp [s^-2], Ki [s^-3], Kd [s^-1], derivative-filter pole [rad/s]) for loop bandwidth
    ``omega_c`` on a free mass: ``Kp = w^2``, ``Kd = 1.6 w`` (damping 0.8), ``Ki = 0.1 w^3``,
    derivative filter at 5 w."""
    return omega_c**2, 0.1 * omega_c**3, 1.6 * omega_c, 5.0 * omega_c


class _PID:
    """Positional PID per axis, Tustin discretisation, filtered derivative, anti-windup."""

    def __init__(self, gains: list[tuple[float, float, float, float]], h: float) -> None:
        self.kp = [g[0] for g in gains]
        self.ki = [g[1] for g in gains]
        self.kd = [g[2] for g in gains]
        p = [min(g[3], 0.8 * math.pi / h) for g in gains]  # keep the pole below Nyquist
        # Tustin: s -> (2/h)(z-1)/(z+1); D(s) = Kd s p/(s + p)
        self.cd = [(2 - pj * h) / (2 + pj * h) for pj in p]
        self.gd = [2 * pj / (2 + pj * h) for pj in p]
        self.h = h
        self.integ = [0.0] * len(gains)
        self.deriv = [0.0] * len(gains)
        self.e_prev = [0.0] * len(gains)

    def step(self, errors: list[float]) -> list[float]:
        out = []
        for a, e in enumerate(errors):
            self.deriv[a] = self.cd[a] * self.deriv[a] + self.gd[a] * (e - self.e_prev[a])
            trial = self.integ[a] + 0.5 * self.h * (e + self.e_prev[a])
            u = self.kp[a] * e + self.ki[a] * trial + self.kd[a] * self.deriv[a]
            if abs(u) < F_MAX or u * e < 0:  # conditional integration (anti-windup)
                self.integ[a] = trial
            else:
                u = self.kp[a] * e + self.ki[a] * self.integ[a] + self.kd[a] * self.deriv[a]
            self.e_prev[a] = e
            out.append(min(max(u, -F_MAX), F_MAX))
        return out


# -------------------------------------------------------------------------- geometry


def _frame(phi: float) -> tuple[float, float, float, float]:
    """In-plane rotation taking frame-s components into a frame turned by ``phi`` about z:
    ``[[cos, sin], [-sin, cos]]`` (row-major)."""
    c, s = math.cos(phi), math.sin(phi)
    return c, s, -s, c


# ------------------------------------------------------------------------ simulation


def _noises(plan, rng_base) -> dict[str, np.ndarray]:
    """All noise series of one run (own streams, own synthesis)."""
    sc = plan.scenario
    n, fs = sc.n, sc.sample_rate
    sig = plan.cfg_sigmas
    bg = sc.background

    def rng(tag: int, a: int = 0) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence([rng_base, 0xF0E1, tag, a]))

    out = {"readout": np.zeros((4, n)), "acc": np.zeros((4, n)), "ele": np.zeros((4, n)),
           "fb": np.zeros((2, n))}  # fmt: skip
    for a in range(4):
        s_m = sig["m1" if a < 2 else "m2"]
        out["readout"][a] = rng(1, a).standard_normal(n) * s_m
        out["acc"][a] = rng(2, a).standard_normal(n) * sig["acc"]
        out["ele"][a] = rng(3, a).standard_normal(n) * sig["ele"]
        if bg is not None:
            psd_m = 2 * s_m**2 / fs
            out["readout"][a] += ar_sum_noise(n, fs, bg.readout_gamma, bg.readout_f_c, psd_m,
                                              rng(4, a))  # fmt: skip
            psd_e = 2 * sig["ele"] ** 2 / fs
            out["ele"][a] += ar_sum_noise(n, fs, 2.0, bg.acc_f_lo, psd_e, rng(5, a))
            out["ele"][a] += blue_noise(n, fs, bg.acc_f_hi, psd_e, rng(6, a))
    for j in range(2):
        out["fb"][j] = rng(7, j).standard_normal(n) * sig["fb"]
    return out


def run_foreign(plan) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Simulate a :class:`tmopt.mismatch.realistic.Plan` -> (recorded channels, true state).

    Raises :class:`tmopt.mismatch.generate.GenerationError` when a test mass leaves the
    electrode gap (a diverged loop is not a recording).
    """
    from tmopt.mismatch.generate import GenerationError

    sc, b = plan.scenario, plan.builder
    n, fs = sc.n, sc.sample_rate
    h = 1.0 / fs
    t_axis = np.arange(n) * h
    rng = np.random.default_rng(np.random.SeedSequence([plan.seed, 0xF0]))
    wc = [rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.0), rng.uniform(0.1, 0.3),
          rng.uniform(0.1, 0.3)]  # fmt: skip
    pid = _PID([pid_gains(w) for w in wc], h)
    noise = _noises(plan, plan.seed)
    k = [float(v) for v in sc.stiffness]
    fd = [float(v) for v in sc.bias]
    fb_bias = (0.0, 0.0)
    geo = b.geometry
    wa, wb = _frame(geo.phi1), _frame(geo.phi2)
    sep = geo.separation
    lever = ((0.5 * sep, 0.0), (-0.5 * sep, 0.0))  # TM1, TM2 centres in frame s (z = 0)
    # the injections' named hooks (a validated container; the physics is this module's)
    pert = b.perturbations()

    def hook(value):
        return None if pert is None or value is None else np.asarray(value, float)

    gain = hook(pert and pert.actuation_gain)
    delay = hook(pert and pert.actuation_delay)
    qstep = hook(pert and pert.actuation_step)
    dk = hook(pert and pert.stiffness_change)
    coupling = hook(pert and pert.stiffness_coupling)
    cubic = hook(pert and pert.cubic_stiffness)
    force = hook(pert and pert.force)
    omega, omega_dot = hook(pert and pert.omega), hook(pert and pert.omega_dot)
    readout = hook(pert and pert.readout)
    ooc = [o for o in plan.ooc if o.spec.force is not None]
    refs = plan.refs

    r = [0.0] * 4
    v = [0.0] * 4
    cmd_hist = np.zeros((4, n))
    rec = {name: np.zeros(n) for name in ("x1", "x2", "y1", "y2", "acc_x1", "acc_x2", "acc_y1",
                                          "acc_y2", "force_x1", "force_x2", "force_y1",
                                          "force_y2")}  # fmt: skip
    true_r = np.zeros((4, n))
    axes = ("x1", "x2", "y1", "y2")

    def applied_cmd(a: int, idx: int) -> float:
        """Command acting on axis a during sample interval ``idx`` (after delay etc.)."""
        u = cmd_hist[a, idx] if idx >= 0 else 0.0
        if qstep is not None and qstep[a] > 0:
            u = qstep[a] * math.floor(u / qstep[a] + 0.5)
        if gain is not None:
            u *= 1.0 + gain[a, max(idx, 0)]
        return u

    def accel(tt: float, i: int, rr, vv, uu) -> list[float]:
        """True acceleration of the four axes at time tt (sample interval i)."""
        fbx = fb_bias[0] + noise["fb"][0, i]
        fby = fb_bias[1] + noise["fb"][1, i]
        fb = (wa[0] * fbx + wa[1] * fby, wb[0] * fbx + wb[1] * fby,
              wa[2] * fbx + wa[3] * fby, wb[2] * fbx + wb[3] * fby)  # fmt: skip
        out = []
        for a in range(4):
            kk = k[a] + (dk[a, i] if dk is not None else 0.0)
            acc = kk * rr[a] + uu[a] + noise["ele"][a, i] + fd[a] - fb[a]
            if coupling is not None:
                acc += sum(coupling[a, c] * rr[c] for c in range(4))
            if cubic is not None:
                acc += cubic[a] * rr[a] ** 3
            if force is not None:
                acc += force[a, i]
            out.append(acc)
        if omega is not None:
            _rotation(out, i, rr, vv, omega, omega_dot, wa, wb, lever)
        if ooc:
            ra, va, ua = np.array(rr), np.array(vv), np.array(uu)
            for o in ooc:
                out = [x + float(y) for x, y in zip(out, o.spec.force(o, tt, ra, va, ua))]
        return out

    def rk4(tt: float, i: int, dt: float, uu: list[float]) -> None:
        a1 = accel(tt, i, r, v, uu)
        r2 = [r[a] + 0.5 * dt * v[a] for a in range(4)]
        v2 = [v[a] + 0.5 * dt * a1[a] for a in range(4)]
        a2 = accel(tt + 0.5 * dt, i, r2, v2, uu)
        r3 = [r[a] + 0.5 * dt * v2[a] for a in range(4)]
        v3 = [v[a] + 0.5 * dt * a2[a] for a in range(4)]
        a3 = accel(tt + 0.5 * dt, i, r3, v3, uu)
        r4 = [r[a] + dt * v3[a] for a in range(4)]
        v4 = [v[a] + dt * a3[a] for a in range(4)]
        a4 = accel(tt + dt, i, r4, v4, uu)
        for a in range(4):
            r[a] += dt / 6 * (v[a] + 2 * v2[a] + 2 * v3[a] + v4[a])
            v[a] += dt / 6 * (a1[a] + 2 * a2[a] + 2 * a3[a] + a4[a])

    lag = [0] * 4
    split = [0.0] * 4
    if delay is not None:
        for a in range(4):
            lag[a] = int(math.floor(delay[a] / h + 1e-12))
            split[a] = delay[a] - lag[a] * h  # the older command acts for this long
    seen = r  # what the readout reads: the position at t_n, or the last step's mean
    for i in range(n):
        tt = t_axis[i]
        meas = []
        for a in range(4):
            pos = seen[a] if readout is None else sum(readout[a, c] * seen[c] for c in range(4))
            meas.append(pos + noise["readout"][a, i])
        cmd = pid.step([refs[a, i] - meas[a] for a in range(4)])
        cmd_hist[:, i] = cmd
        true_r[:, i] = r
        # the force acting now: the command issued lag (and lag+1) samples ago
        early = [applied_cmd(a, i - lag[a] - 1) if split[a] > 0 else applied_cmd(a, i - lag[a])
                 for a in range(4)]  # fmt: skip
        late = [applied_cmd(a, i - lag[a]) for a in range(4)]
        # the held accelerometer: k r(t_n) plus the force over [t_n, t_n+1) -- its interval
        # average where a delayed command switches inside the step (the force at the
        # instant t_n alone would make any delay > 0 a whole-sample jump)
        over_step = [(split[a] * early[a] + (h - split[a]) * late[a]) / h for a in range(4)]
        acc_held = accel(tt, i, r, v, over_step)
        v0, r0 = list(v), list(r)
        cut = max(split) if any(s > 0 for s in split) else 0.0
        if sc.integrator != "rk4":
            m = sc.substeps
            for j in range(m):  # the first sub-step's acceleration is the recorded one
                a_j = acc_held if j == 0 else accel(tt + j * h / m, i, r, v, over_step)
                _euler_step(sc.integrator, r, v, a_j, h / m)
        elif cut > 0:
            # integrate to the latest switch with each axis's early/late command: split the
            # step at every distinct switch time
            times = sorted({s for s in split if s > 0} | {h})
            t_prev = 0.0
            for ts in times:
                uu = [early[a] if t_prev < split[a] else late[a] for a in range(4)]
                rk4(tt + t_prev, i, ts - t_prev, uu)
                t_prev = ts
        else:
            rk4(tt, i, h, late)
        # the accelerometer read at the step's end: k r(t_n+1) plus the same step force
        # (code that measures after the state update; docs/mismatch.md 9.25)
        acc_end = accel(tt + h, i, r, v, over_step) if sc.acc_convention == "end" else None
        for a, name in enumerate(axes):
            rec[name][i] = meas[a]
            if sc.acc_convention == "held":  # (and every Euler step: _check_integrator)
                rec[f"acc_{name}"][i] = acc_held[a] + noise["acc"][a, i]
            elif sc.acc_convention == "end":
                rec[f"acc_{name}"][i] = acc_end[a] + noise["acc"][a, i]
            else:
                rec[f"acc_{name}"][i] = (v[a] - v0[a]) / h + noise["acc"][a, i]
            rec[f"force_{name}"][i] = cmd[a] if sc.force_stamp == "applied" else (
                cmd_hist[a, i - 1] if i > 0 else 0.0)
        if sc.readout_sampling == "mean":  # the next sample reads this step's mean
            seen = _step_mean(r0, r, v0, v, h)
        else:
            seen = r
        if not all(abs(x) < GAP_BOUND for x in r):
            raise GenerationError(f"foreign simulation: a test mass left the gap at t = {tt:.1f} "
                                  "s (the loop diverged)")  # fmt: skip
    rec["time"] = t_axis.copy()
    rec["ref_x1"], rec["ref_x2"] = refs[0].copy(), refs[1].copy()
    if omega is not None:
        for j, c in enumerate("xyz"):
            rec[f"sc_omega_{c}"] = omega[j].copy()
            rec[f"sc_omega_dot_{c}"] = omega_dot[j].copy()
    return rec, {"time": t_axis.copy(), "r": true_r}


def _step_mean(r0: list, r1: list, v0: list, v1: list, h: float) -> list:
    """Mean position over a step from its ends: ``(r0 + r1)/2 - h (v1 - v0)/12`` (the
    trapezoid rule with its end correction, Euler-Maclaurin; exact for a cubic, so to
    ``h^4 k a/720`` under a held force) -- an integrating readout."""
    return [0.5 * (a + b) - h * (d - c) / 12.0 for a, b, c, d in zip(r0, r1, v0, v1)]


def _euler_step(kind: str, r: list, v: list, acc: list, h: float) -> None:
    """One Euler step with the acceleration at the step's start, as a hand-written
    simulator may take it: ``symplectic`` (``v += h a; r += h v``, so ``r_{n+1} - 2 r_n +
    r_{n-1} = h^2 a_n``) or ``explicit`` (``r += h v; v += h a``: ``h^2 a_{n-1}``)."""
    for a in range(4):
        if kind == "symplectic":
            v[a] += h * acc[a]
            r[a] += h * v[a]
        else:
            r[a] += h * v[a]
            v[a] += h * acc[a]


def _rotation(out, i, rr, vv, omega, omega_dot, wa, wb, lever) -> None:
    """Eq. 1's apparent accelerations at each TM: ``-w' x p - w x (w x p) - 2 w x p'`` with
    ``p`` the TM centre from the spacecraft CoM (lever arm + displacement, frame s)."""
    w = (omega[0, i], omega[1, i], omega[2, i])
    wd = (omega_dot[0, i], omega_dot[1, i], omega_dot[2, i])
    for tm, (ix, iy, m) in enumerate(((0, 2, wa), (1, 3, wb))):
        # TM frame -> frame s: transpose of m
        px = lever[tm][0] + m[0] * rr[ix] + m[2] * rr[iy]
        py = lever[tm][1] + m[1] * rr[ix] + m[3] * rr[iy]
        qx = m[0] * vv[ix] + m[2] * vv[iy]
        qy = m[1] * vv[ix] + m[3] * vv[iy]
        p = (px, py, 0.0)
        q = (qx, qy, 0.0)
        a1 = _cross(wd, p)
        wp = _cross(w, p)
        a2 = _cross(w, wp)
        a3 = _cross(w, q)
        ax = -a1[0] - a2[0] - 2 * a3[0]
        ay = -a1[1] - a2[1] - 2 * a3[1]
        out[ix] += m[0] * ax + m[1] * ay
        out[iy] += m[2] * ax + m[3] * ay


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
