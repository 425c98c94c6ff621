"""The closed loop of one design, step by step, and its compiled batch driver.

Every step function here is ``register_jitable``: numba compiles it into the batched
kernel, while a plain Python call runs the very same source in the interpreter.  The
per-design reference loop of the benchmark (``run_design`` called from Python) is hence
the same model, line for line, as the compiled batch.  The batch kernel runs the nominal model
in lock-step groups (``run_group``: the run is the SIMD lane, each lane doing
``run_design``'s operations in the same order, so the same bits); ``run_design`` itself
runs the perturbed model and is the reference the groups are tested against.  All
compiled code lives in this one file because numba's on-disk cache only watches the file
of the cached function.

Units are SI per unit mass throughout: positions m, forces m s^-2, stiffness s^-2.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.extending import register_jitable

from tmopt.physics.dynamics import zoh_coefficients  # the exact ZOH step of Eqs. 1-2

# --- layout of the packed parameter vector ``par`` (see simulator._pack_parameters) ---
P_DT = 0
P_K = 1  # 4 stiffnesses [k1xx, k2xx, k1yy, k2yy]
P_FD = 5  # 4 bias disturbances [fD1x, fD2x, fD1y, fD2y]
P_FB = 9  # 2 spacecraft acceleration bias components [x_s, y_s]
P_WSA = 11  # W_sa[:2, :2] row-major
P_WSB = 15  # W_sb[:2, :2] row-major
P_KC = 19  # 4 regression coefficients K of Eq. 11
P_FMAX = 23
P_XGAIN = 24  # 3 base gains of the sensitive-axis controller [Kp, Ki, Kd]
P_YGAIN = 27  # 3 gains of the non-sensitive-axis PID
P_ESCALE = 30
P_ECSCALE = 31
P_ETA = 32
P_MOM = 33
P_GLO = 34
P_GHI = 35
P_BMIN = 36
P_LAM = 37
P_P0 = 38
P_SX = 39
P_SY = 40
P_SOUT = 41
P_BOUND = 42
P_FRBF = 43  # 1.0: FRBF-PID on the sensitive axes, 0.0: plain incremental PID
P_STEADY = 44  # first sample index of the "steady" window for the tracking summary
P_YFILT = 45  # derivative-filter pole a = exp(-dt / tau_f) of the non-sensitive PID (0: none)
P_JAC = 46  # FRBF plant-Jacobian sign: 0.0 constant +1, 1.0 online sign(dy/du) estimate
P_MASK = 47  # 5 flags: 1.0 = theta column identified by the RLS, 0.0 = left out
N_PAR = 52

N_CH = 16  # recorded channels: x (4), x measured (4), acc measured (4), force commanded (4)
N_GAIN = 6  # recorded gains [Kp, Ki, Kd] of the TM1 and TM2 sensitive-axis controllers
# summary columns: max|r - x| (x1, x2), the same for t >= steady_after (x1, x2),
# max|r| realised (x1, x2, y1, y2), max|u| commanded (x1, x2, y1, y2)
N_SUM = 12
SUM_XMAX = 4
SUM_UMAX = 8
N_THETA = 5
N_MF = 7  # Gaussian memberships per input
N_RULE = N_MF * N_MF

# --- layout of the perturbation vector ``pp`` (see simulator._pack_perturbations) ---
# Flags are 1.0 (on) / 0.0 (off); with PP_ON = 0 the kernel runs the unperturbed model's
# arithmetic unchanged (bit-identical to the simulator before the hooks existed).
PP_ON = 0
PP_GAIN = 1  # actuation gain series ps[S_GAIN + a]
PP_DELAY = 2  # actuation delays pp[PP_TAU + a]
PP_QUANT = 3  # actuation quantisation steps pp[PP_Q + a]
PP_DK = 4  # stiffness change series ps[S_DK + a]
PP_COUPLE = 5  # extra stiffness matrix pp[PP_C + 4 a + b]
PP_CUBIC = 6  # cubic stiffness pp[PP_K3 + a]
PP_FORCE = 7  # extra force series ps[S_FORCE + a]
PP_ROT = 8  # spacecraft rotation series ps[S_OMEGA + j], ps[S_OMEGA_DOT + j]
PP_READ = 9  # readout matrix pp[PP_M + 4 a + b]
PP_TAU = 10
PP_Q = 14
PP_C = 18
PP_K3 = 34
PP_M = 38
PP_R01 = 54  # lever arm CoM -> TM1, frame s (3)
PP_R02 = 57  # lever arm CoM -> TM2, frame s (3)
N_PP = 60
# rows of the perturbation series ``ps`` (18, N)
S_GAIN, S_DK, S_FORCE, S_OMEGA, S_OMEGA_DOT, N_S = 0, 4, 8, 12, 15, 18

# divergence status codes (status[:, 0]); status[:, 1] is the sample index
OK, OUT_X1, OUT_X2, OUT_Y1, OUT_Y2, BAD_FORCE, BAD_ESTIMATE = 0, 1, 2, 3, 4, 5, 6


@register_jitable
def pid_increment(e, e1, e2, u_prev, kp, ki, kd, fmax):
    """Incremental PID of Eq. 28 with output limit and integral freeze (Sec. 3.3).

    ``u_n = u_{n-1} + Kp (e_n - e_{n-1}) + Ki e_n + Kd (e_n - 2 e_{n-1} + e_{n-2})``,
    clipped to ``+-fmax``.  While the output sits at the limit (``|u_{n-1}| = fmax``) the
    integral increment ``Ki e_n`` is dropped if it pushes further into saturation
    (conditional integration: the integral is frozen, it can still unwind).
    """
    du_i = ki * e
    if abs(u_prev) >= fmax and du_i * u_prev > 0:
        du_i = 0.0
    u = u_prev + kp * (e - e1) + du_i + kd * (e - 2.0 * e1 + e2)
    return min(max(u, -fmax), fmax)


@register_jitable
def filtered_pid_increment(e, e1, u_prev, d_prev, kp, ki, kd, a, fmax):
    """Incremental PID with a first-order filter on the derivative term -> (u_n, D_n).

    The derivative term in position form is ``D_n = a D_{n-1} + (1 - a) Kd (e_n -
    e_{n-1})`` with ``a = exp(-dt / tau_f)`` (the "practical" PID of Astrom & Hagglund,
    *Advanced PID Control*, 2006, Sec. 3.3); ``u_n = u_{n-1} + Kp (e_n - e_{n-1}) + Ki e_n +
    (D_n - D_{n-1})``.  ``a = 0`` is Eq. 28's ``Kd (e_n - 2 e_{n-1} + e_{n-2})``.  Output
    limit and integral freeze as :func:`pid_increment`.
    """
    d = a * d_prev + (1.0 - a) * kd * (e - e1)
    du_i = ki * e
    if abs(u_prev) >= fmax and du_i * u_prev > 0:
        du_i = 0.0
    u = u_prev + kp * (e - e1) + du_i + (d - d_prev)
    return min(max(u, -fmax), fmax), d


@register_jitable
def frbf_forward(x1, x2, c, b, w, f2, f3, f4):
    """Eqs. 22-25: Gaussian memberships, 49 product rules, linear output layer.

    ``f2[i, j] = exp(-(x_i - c_ij)^2 / b_ij^2)``, ``f3[7 j1 + j2] = f2[0, j1] f2[1, j2]``,
    ``f4[m] = sum_l w[m, l] f3[l]``.
    """
    for j in range(N_MF):
        d = x1 - c[0, j]
        f2[0, j] = math.exp(-d * d / (b[0, j] * b[0, j]))
        d = x2 - c[1, j]
        f2[1, j] = math.exp(-d * d / (b[1, j] * b[1, j]))
    for j1 in range(N_MF):
        for j2 in range(N_MF):
            f3[j1 * N_MF + j2] = f2[0, j1] * f2[1, j2]
    # the three sums side by side (each in the order r = 0..48, so the same bits): three
    # independent chains of additions instead of one after the other
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for r in range(N_RULE):
        s0 += w[0, r] * f3[r]
        s1 += w[1, r] * f3[r]
        s2 += w[2, r] * f3[r]
    f4[0] = s0
    f4[1] = s1
    f4[2] = s2


@register_jitable
def frbf_learn(x1, x2, g, c, b, w, dc, db, dw, f3, q, eta, mom, bmin, s):
    """Eqs. 26-27: one gradient-descent-with-momentum step on ``w``, ``c`` and ``b``.

    ``g[m] = dE/df4_m`` (already chained through the PID and the plant-Jacobian sign).
    Over the memberships ``f2 = exp(-(x - c)^2 / b^2)``: ``df2/dc = 2 (x - c) / b^2 f2``,
    ``df2/db = 2 (x - c)^2 / b^3 f2``.
    Every parameter moves by ``-eta dE/dp + mom (p_{n-1} - p_{n-2})``; ``dc, db, dw`` hold
    the previous moves.  Widths are kept >= ``bmin`` so the memberships stay defined.
    ``q`` (49,) and ``s`` (2, 7) are work arrays.
    """
    for r in range(N_RULE):  # dE/df3_r with the weights before the update
        q[r] = (g[0] * w[0, r] + g[1] * w[1, r] + g[2] * w[2, r]) * f3[r]
    for m in range(3):
        for r in range(N_RULE):
            step = -eta * g[m] * f3[r] + mom * dw[m, r]
            w[m, r] += step
            dw[m, r] = step
    # per membership j, the sums over its rules (first input: rules 7 j + k, second: 7 k + j),
    # each in the order k = 0..6 as before, but the 14 sums side by side
    for j in range(N_MF):
        s[0, j] = 0.0
        s[1, j] = 0.0
    for k in range(N_MF):
        for j in range(N_MF):
            s[0, j] += q[j * N_MF + k]
            s[1, j] += q[k * N_MF + j]
    for j in range(N_MF):
        _learn_membership(0, j, x1, s[0, j], c, b, dc, db, eta, mom, bmin)
        _learn_membership(1, j, x2, s[1, j], c, b, dc, db, eta, mom, bmin)


@register_jitable
def _learn_membership(i, j, x, s, c, b, dc, db, eta, mom, bmin):
    """Centre/width step for one membership; ``s = sum over its rules of dE/df3 f3``."""
    c[i, j], dc[i, j], b[i, j], db[i, j] = membership_step(
        x, s, c[i, j], b[i, j], dc[i, j], db[i, j], eta, mom, bmin)


@register_jitable
def membership_step(x, s, c, bb, dc, db, eta, mom, bmin):
    """Eqs. 26-27 for one Gaussian membership -> new (c, dc, b, db).

    ``df2/dc = 2 (x - c) / b^2 f2`` and ``df2/db = 2 (x - c)^2 / b^3 f2``; ``s`` is the sum
    over the membership's rules of ``dE/df3 f3``; the width is kept >= ``bmin``.
    """
    d = x - c
    grad_c = s * 2.0 * d / (bb * bb)
    grad_b = s * 2.0 * d * d / (bb * bb * bb)
    step_c = -eta * grad_c + mom * dc
    step_b = -eta * grad_b + mom * db
    b = max(bb + step_b, bmin)
    return c + step_c, step_c, b, b - bb


@register_jitable
def rls_update(theta, P, psi, y, lam, ppsi):
    """Eq. 16 (recursive least squares with forgetting factor ``lam``), in place.

    ``K = P psi / (lam + psi' P psi)``, ``theta += K (y - psi' theta_prev)``,
    ``P = (P - K psi' P) / lam`` (written with ``P psi`` so P stays symmetric).
    """
    n = theta.shape[0]
    den = lam
    err = y
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += P[i, j] * psi[j]
        ppsi[i] = s
        den += psi[i] * s
        err -= psi[i] * theta[i]
    for i in range(n):
        theta[i] += ppsi[i] / den * err
    for i in range(n):
        for j in range(n):
            P[i, j] = (P[i, j] - ppsi[i] * ppsi[j] / den) / lam


@register_jitable
def _clip1(x):
    return min(max(x, -1.0), 1.0)


@register_jitable
def run_design(
    i, ref1, ref2, refy, noise, par, c0, b0, out_ch, out_th, out_gain, summary, status,
    record, pp, ps,
):
    """Simulate design ``i`` for ``ref1.shape[1]`` samples and write its outputs.

    One sample n: measure (+N_m), control (FRBF-PID or PID on x, the filtered PID on y),
    apply the commanded force + N_ele + f_D - f_B (f_B^s rotated into frames a and b),
    measure the acceleration at t_n (+N_acc; ``k r_n`` plus the force held over [t_n,
    t_{n+1}), or its interval average when a delayed command switches inside the step),
    form the regression of Eqs. 10-15, update the RLS on the identified columns, and
    advance the state exactly to t_{n+1}.  On divergence (|r| > bound, non-finite force or
    estimate) the design stops and its remaining samples hold their last values.

    ``pp`` / ``ps`` carry the instrument perturbations (layout above, meaning in
    ``simulator.Perturbations``); with ``pp[PP_ON] == 0`` none of their code runs.
    ``refy`` (B, 2, N) are the non-sensitive-axis references of y1, y2 (their loop tracks
    them like a drag-free suspension with a set point); shape (1, 2, 1) = held at zero.
    """
    n_steps = ref1.shape[1]
    moves_y = refy.shape[0] == ref1.shape[0] and refy.shape[2] == n_steps
    dt = par[P_DT]
    frbf = par[P_FRBF] > 0.5
    pert = pp[PP_ON] > 0.5
    coef = np.empty((4, 3))
    for a in range(4):
        coef[a, 0], coef[a, 1], coef[a, 2] = zoh_coefficients(par[P_K + a], dt)
    # perturbation work arrays (tiny when off)
    split_at = np.zeros(4)  # delay: fraction delta of the step with the older command
    lag = np.zeros(4, dtype=np.int64)  # delay: whole samples m
    coef1 = np.empty((4, 3))  # ZOH over delta and over dt - delta
    coef2 = np.empty((4, 3))
    uhist = np.zeros((4, n_steps if pert and pp[PP_DELAY] > 0.5 else 1))
    extra = np.zeros(4)
    early = np.zeros(4)
    late = np.zeros(4)
    if pert and pp[PP_DELAY] > 0.5:
        _delay_setup(par, pp, dt, lag, split_at, coef1, coef2)
    pos = np.zeros(4)
    vel = np.zeros(4)
    meas = np.zeros(4)
    meas_prev = np.zeros(4)  # y_{n-1} of the online Jacobian estimate
    pos_n = np.zeros(4)
    u = np.zeros(4)
    e1 = np.zeros(4)
    e2 = np.zeros(4)
    dfilt = np.zeros(4)  # filtered derivative term D_{n-1} of the non-sensitive PID
    gains = np.empty(N_GAIN)
    for a in range(2):
        for m in range(3):
            gains[3 * a + m] = par[P_XGAIN + m]
    c = np.empty((2, 2, N_MF))
    b = np.empty((2, 2, N_MF))
    for t in range(2):
        for k in range(2):
            for j in range(N_MF):
                c[t, k, j] = c0[j]
                b[t, k, j] = b0
    w = np.zeros((2, 3, N_RULE))
    dc = np.zeros((2, 2, N_MF))
    db = np.zeros((2, 2, N_MF))
    dw = np.zeros((2, 3, N_RULE))
    f2 = np.empty((2, N_MF))
    f3 = np.empty(N_RULE)
    f4 = np.empty(3)
    q = np.empty(N_RULE)
    g = np.empty(3)
    msum = np.empty((2, N_MF))  # per-membership sums of frbf_learn
    theta = np.zeros(N_THETA)
    P = np.zeros((N_THETA, N_THETA))
    for k in range(N_THETA):
        # a column left out has zero prior covariance: its estimate never moves and it
        # adds exact zeros to every sum, so the others follow the reduced RLS bit for bit
        P[k, k] = par[P_P0] * par[P_MASK + k]
    psi = np.empty(N_THETA)
    ppsi = np.empty(N_THETA)
    acc = np.empty(4)
    fb = np.empty(4)
    psi_scale = np.array([par[P_SX], par[P_SX], par[P_SY], par[P_SY], 1.0])
    ref = np.zeros(4)
    code = OK
    last = n_steps - 1
    for n in range(n_steps):
        ref[0] = ref1[i, n]
        ref[1] = ref2[i, n]
        if moves_y:
            ref[2] = refy[i, 0, n]
            ref[3] = refy[i, 1, n]
        for a in range(4):
            meas_prev[a] = meas[a]
            if pert and pp[PP_READ] > 0.5:
                meas[a] = _readout(a, pos, pp) + noise[a, n]
            else:
                meas[a] = pos[a] + noise[a, n]
            e = ref[a] - meas[a]
            if a < 2 and frbf:
                u[a] = _frbf_pid_axis(
                    e, e1[a], e2[a], u[a], meas[a] - meas_prev[a], c[a], b[a], w[a], dc[a],
                    db[a], dw[a], f2, f3, f4, q, g, msum, gains, 3 * a, par, dt,
                )
            elif a < 2:
                u[a] = pid_increment(
                    e, e1[a], e2[a], u[a], par[P_XGAIN], par[P_XGAIN + 1], par[P_XGAIN + 2],
                    par[P_FMAX],
                )
            elif par[P_YFILT] > 0.0:
                u[a], dfilt[a] = filtered_pid_increment(
                    e, e1[a], u[a], dfilt[a], par[P_YGAIN], par[P_YGAIN + 1],
                    par[P_YGAIN + 2], par[P_YFILT], par[P_FMAX],
                )
            else:
                u[a] = pid_increment(
                    e, e1[a], e2[a], u[a], par[P_YGAIN], par[P_YGAIN + 1], par[P_YGAIN + 2],
                    par[P_FMAX],
                )
            e2[a] = e1[a]
            e1[a] = e
            if not math.isfinite(u[a]):
                code = BAD_FORCE
        # spacecraft acceleration f_B (frame s, bias + white noise) seen in frames a and b
        fbx = par[P_FB] + noise[12, n]
        fby = par[P_FB + 1] + noise[13, n]
        fb[0] = par[P_WSA] * fbx + par[P_WSA + 1] * fby
        fb[2] = par[P_WSA + 2] * fbx + par[P_WSA + 3] * fby
        fb[1] = par[P_WSB] * fbx + par[P_WSB + 1] * fby
        fb[3] = par[P_WSB + 2] * fbx + par[P_WSB + 3] * fby
        for a in range(4):
            pos_n[a] = pos[a]
        if pert:
            # every perturbation force from the state at t_n, before any axis moves
            _perturbation_forces(n, pos, vel, par, pp, ps, extra)
            _actuation(n, u, pp, ps, uhist, lag, split_at, early, late)
        y_reg = 0.0
        for a in range(4):
            if pert:
                # same association as below, so zero perturbations change no bit
                applied = early[a] + noise[8 + a, n] + par[P_FD + a] - fb[a] + extra[a]
            else:
                applied = u[a] + noise[8 + a, n] + par[P_FD + a] - fb[a]
            applied2 = applied
            if pert and split_at[a] > 0.0:
                # the command switches inside the step: the accelerometer reports the
                # interval average, as it does (trivially) for a force held over the step
                applied2 = late[a] + noise[8 + a, n] + par[P_FD + a] - fb[a] + extra[a]
                mean = (split_at[a] * applied + (dt - split_at[a]) * applied2) / dt
                acc[a] = par[P_K + a] * pos[a] + mean + noise[4 + a, n]
            else:
                acc[a] = par[P_K + a] * pos[a] + applied + noise[4 + a, n]  # r'' + N_acc
            # Eqs. 10-15: y = K.(r'' - f_e) with measured r'' and commanded f_e
            y_reg += par[P_KC + a] * (acc[a] - u[a])
            psi[a] = par[P_KC + a] * meas[a] / psi_scale[a]
            if pert and split_at[a] > 0.0:
                # delayed actuation switches command inside the step: two exact ZOH pieces
                _zoh_advance(a, pos, vel, par[P_K + a], coef1, applied)
                _zoh_advance(a, pos, vel, par[P_K + a], coef2, applied2)
            else:
                # propagate this axis exactly to t_{n+1} (force held over the interval)
                p, v = pos[a], vel[a]
                pos[a] = coef[a, 0] * p + coef[a, 1] * v + coef[a, 2] * applied
                vel[a] = par[P_K + a] * coef[a, 1] * p + coef[a, 0] * v + coef[a, 1] * applied
        psi[4] = 1.0
        rls_update(theta, P, psi, y_reg / par[P_SOUT], par[P_LAM], ppsi)
        for k in range(N_THETA):
            if par[P_MASK + k] > 0.5:
                out_th[i, n, k] = theta[k] * par[P_SOUT] / psi_scale[k]
                if not math.isfinite(out_th[i, n, k]):
                    code = BAD_ESTIMATE
            else:
                out_th[i, n, k] = math.nan  # not identified (SimulationConfig.rls_columns)
        _record(i, n, pos_n, meas, acc, u, gains, par, ref, out_ch, out_gain, summary, record)
        if code == OK:
            for a in range(4):
                if not (abs(pos[a]) <= par[P_BOUND]):  # also catches NaN
                    code = OUT_X1 + a
                    break
        if code != OK:
            last = n
            break
    end_run(i, code, last, par, out_th, out_ch, out_gain, status, record)


@register_jitable
def end_run(i, code, last, par, out_th, out_ch, out_gain, status, record):
    """Status of run ``i``; after a divergence at sample ``last`` its outputs hold their
    last finite values to the end (finite, never NaN)."""
    n_steps = out_th.shape[1]
    status[i, 0] = code
    status[i, 1] = last
    if code == BAD_FORCE or code == BAD_ESTIMATE:
        # sample `last` itself is not finite: hold the one before it (zeros at n = 0)
        last -= 1
        if last < 0:
            last = 0
            for k in range(N_THETA):
                if par[P_MASK + k] > 0.5:
                    out_th[i, 0, k] = 0.0
            if record:
                for ch in range(N_CH):
                    out_ch[ch, i, 0] = 0.0
                for ch in range(N_GAIN):
                    out_gain[ch, i, 0] = 0.0
    for n in range(last + 1, n_steps):  # hold after divergence: finite, never NaN
        for k in range(N_THETA):
            out_th[i, n, k] = out_th[i, last, k]
        if record:
            for ch in range(N_CH):
                out_ch[ch, i, n] = out_ch[ch, i, last]
            for ch in range(N_GAIN):
                out_gain[ch, i, n] = out_gain[ch, i, last]


@register_jitable
def _zoh_advance(a, pos, vel, k, cf, force):
    """Exact ZOH step of axis ``a`` with coefficients ``cf[a]`` (any step length)."""
    p, v = pos[a], vel[a]
    pos[a] = cf[a, 0] * p + cf[a, 1] * v + cf[a, 2] * force
    vel[a] = k * cf[a, 1] * p + cf[a, 0] * v + cf[a, 1] * force


@register_jitable
def _delay_setup(par, pp, dt, lag, split_at, coef1, coef2):
    """Split each delay tau = m dt + delta (0 <= delta < dt) and the ZOH over delta, dt - delta.

    The applied command is ``u(t - tau)`` with ``u`` piecewise constant (ZOH), so over
    [t_n, t_n + delta) it is u_{n-m-1} and over [t_n + delta, t_{n+1}) it is u_{n-m}:
    two exact ZOH pieces, no interpolation.
    """
    for a in range(4):
        tau = pp[PP_TAU + a]
        m = int(math.floor(tau / dt + 1e-9))  # 1e-9: tau = m dt written in decimal
        delta = tau - m * dt
        if delta < 1e-9 * dt:
            delta = 0.0
        lag[a] = m
        split_at[a] = delta
        k = par[P_K + a]
        coef1[a, 0], coef1[a, 1], coef1[a, 2] = zoh_coefficients(k, max(delta, 1e-300))
        coef2[a, 0], coef2[a, 1], coef2[a, 2] = zoh_coefficients(k, dt - delta)


@register_jitable
def _actuation(n, u, pp, ps, uhist, lag, split_at, early, late):
    """Force the actuators apply over [t_n, t_n + delta) (``early``) and after (``late``).

    Chain per axis: command u -> delay tau (held commands, see ``_delay_setup``) ->
    quantisation ``q * floor(u / q + 1/2)`` -> gain ``(1 + g_n)``.  Commands before t_0
    are 0 (the controller starts from rest).
    """
    delay = pp[PP_DELAY] > 0.5
    for a in range(4):
        if delay:
            uhist[a, n] = u[a]
            j = n - lag[a]
            late[a] = uhist[a, j] if j >= 0 else 0.0
            early[a] = (uhist[a, j - 1] if j >= 1 else 0.0) if split_at[a] > 0.0 else late[a]
        else:
            late[a] = u[a]
            early[a] = u[a]
        step = pp[PP_Q + a]
        if pp[PP_QUANT] > 0.5 and step > 0.0:
            late[a] = step * math.floor(late[a] / step + 0.5)
            early[a] = step * math.floor(early[a] / step + 0.5)
        if pp[PP_GAIN] > 0.5:
            gain = 1.0 + ps[S_GAIN + a, n]
            late[a] = gain * late[a]
            early[a] = gain * early[a]


@register_jitable
def _readout(a, pos, pp):
    """Displacement readout of axis ``a`` before noise: ``sum_b M[a, b] r_b`` (M = I nominal)."""
    s = 0.0
    for b in range(4):
        s += pp[PP_M + 4 * a + b] * pos[b]
    return s


@register_jitable
def _perturbation_forces(n, pos, vel, par, pp, ps, extra):
    """Extra acceleration of each axis at t_n, held over the step (ZOH of the perturbation).

    ``dk_n r`` (stiffness change), ``sum_b C[a, b] r_b`` (stiffness coupling), ``k3 r^3``
    (cubic stiffness), the external force series, and the rotation terms of Eq. 1.
    """
    for a in range(4):
        f = 0.0
        if pp[PP_DK] > 0.5:
            f += ps[S_DK + a, n] * pos[a]
        if pp[PP_COUPLE] > 0.5:
            for b in range(4):
                f += pp[PP_C + 4 * a + b] * pos[b]
        if pp[PP_CUBIC] > 0.5:
            f += pp[PP_K3 + a] * pos[a] * pos[a] * pos[a]
        if pp[PP_FORCE] > 0.5:
            f += ps[S_FORCE + a, n]
        extra[a] = f
    if pp[PP_ROT] > 0.5:
        _rotation_terms(n, pos, vel, par, pp, ps, 0, 2, P_WSA, PP_R01, extra)
        _rotation_terms(n, pos, vel, par, pp, ps, 1, 3, P_WSB, PP_R02, extra)


@register_jitable
def _rotation_terms(n, pos, vel, par, pp, ps, ax, ay, pw, pr, extra):
    """Eq. 1's rotation terms for one TM: ``rho x w' + 2 rho' x w + w x (rho x w)``.

    ``rho = r0i + W^T r`` is the TM centre from the spacecraft CoM in frame s (lever arm of
    the layout plus the TM displacement), ``w``, ``w'`` the spacecraft rate and angular
    acceleration in frame s; the result is rotated into the TM frame by ``W`` (a rotation
    about z, so only the in-plane block is needed) and added to axes ``ax`` (x), ``ay`` (y).
    """
    w00, w01, w10, w11 = par[pw], par[pw + 1], par[pw + 2], par[pw + 3]
    # TM frame -> s with W^T (z components of r and r' are 0: no z motion is modelled)
    rx = pp[pr] + w00 * pos[ax] + w10 * pos[ay]
    ry = pp[pr + 1] + w01 * pos[ax] + w11 * pos[ay]
    rz = pp[pr + 2]
    vx = w00 * vel[ax] + w10 * vel[ay]
    vy = w01 * vel[ax] + w11 * vel[ay]
    ox, oy, oz = ps[S_OMEGA, n], ps[S_OMEGA + 1, n], ps[S_OMEGA + 2, n]
    dx, dy, dz = ps[S_OMEGA_DOT, n], ps[S_OMEGA_DOT + 1, n], ps[S_OMEGA_DOT + 2, n]
    # rho x w'
    ax_s = ry * dz - rz * dy
    ay_s = rz * dx - rx * dz
    # 2 rho' x w (rho'_z = 0)
    ax_s += 2.0 * (vy * oz)
    ay_s += 2.0 * (-vx * oz)
    # w x (rho x w)
    cx = ry * oz - rz * oy
    cy = rz * ox - rx * oz
    cz = rx * oy - ry * ox
    ax_s += oy * cz - oz * cy
    ay_s += oz * cx - ox * cz
    extra[ax] += w00 * ax_s + w01 * ay_s
    extra[ay] += w10 * ax_s + w11 * ay_s


@register_jitable
def _frbf_pid_axis(
    e, e1, e2, u_prev, dy, c, b, w, dc, db, dw, f2, f3, f4, q, g, msum, gains, at, par, dt
):
    """FRBF-PID (Sec. 3.3, Eqs. 22-28) on one sensitive axis; writes its gains at ``at``.

    Inputs (Eq. 22) are ``e / e_scale`` and ``(de/dt) / ec_scale``, clipped to the
    centres' range [-1, 1].  The network's outputs scale the paper's gain coefficients:
    ``K_m = base_m clip(1 + f4_m, glo, ghi)`` (Eq. 28 with ``f4 = 0`` at ``w = 0``).

    Learning (Eqs. 26-27) descends ``E = e~^2 / 2`` in normalised units, ``e~ = e /
    e_scale`` (clipped) and ``u~ = u / F_max``::

        dE/df4_m = -e~ J base_m d_m / F_max,   d = [e_n - e_{n-1}, e_n, e_n - 2e_{n-1} + e_{n-2}]

    with ``J`` the plant-Jacobian sign (+1, or the online estimate ``sign(dy dU)``); it is
    zero while the output sits at the limit (the applied force then does not depend on the
    gains) and where the gain multiplier is clipped.
    """
    x1, x2 = frbf_inputs(e, e1, par, dt)
    frbf_forward(x1, x2, c, b, w, f2, f3, f4)
    for m in range(3):
        gains[at + m] = frbf_gain(m, f4[m], par)
    u = pid_increment(e, e1, e2, u_prev, gains[at], gains[at + 1], gains[at + 2], par[P_FMAX])
    g[0], g[1], g[2] = frbf_gradient(e, e1, e2, u, u_prev, dy, x1, f4[0], f4[1], f4[2], par)
    frbf_learn(x1, x2, g, c, b, w, dc, db, dw, f3, q, par[P_ETA], par[P_MOM], par[P_BMIN],
               msum)
    return u


@register_jitable
def frbf_inputs(e, e1, par, dt):
    """Eq. 22's network inputs ``e / e_scale`` and ``(de/dt) / ec_scale``, clipped to [-1, 1]."""
    return _clip1(e / par[P_ESCALE]), _clip1((e - e1) / dt / par[P_ECSCALE])


@register_jitable
def frbf_gain(m, f4m, par):
    """Eq. 28's gain ``K_m = base_m clip(1 + f4_m, glo, ghi)``."""
    return par[P_XGAIN + m] * min(max(1.0 + f4m, par[P_GLO]), par[P_GHI])


@register_jitable
def frbf_gradient(e, e1, e2, u, u_prev, dy, x1, f40, f41, f42, par):
    """``dE/df4_m`` (see :func:`_frbf_pid_axis`) for the command ``u`` that followed ``u_prev``."""
    fmax = par[P_FMAX]
    jac = 1.0
    if par[P_JAC] > 0.5:  # the classic online estimate sign(dy/du) from the last step
        s = dy * (u - u_prev)
        jac = 1.0 if s > 0.0 else (-1.0 if s < 0.0 else 0.0)
    if abs(u) >= fmax:
        jac = 0.0
    common = -x1 * jac / fmax
    lo, hi = par[P_GLO], par[P_GHI]
    # zero where the gain multiplier is clipped (the force does not depend on f4_m there)
    g0 = common * par[P_XGAIN] * (e - e1) if lo < 1.0 + f40 < hi else 0.0
    g1 = common * par[P_XGAIN + 1] * e if lo < 1.0 + f41 < hi else 0.0
    g2 = common * par[P_XGAIN + 2] * (e - 2.0 * e1 + e2) if lo < 1.0 + f42 < hi else 0.0
    return g0, g1, g2


@register_jitable
def _record(i, n, pos_n, meas, acc, u, gains, par, ref, out_ch, out_gain, summary, record):
    """Store sample n (true state at t_n) and update the summary (layout: ``N_SUM``).

    ``summary[i]`` = [max|r1 - x1|, max|r2 - x2|, the same over n >= P_STEADY (2),
    max|x1|, max|x2|, max|y1|, max|y2| (true motion), max|u| of x1, x2, y1, y2 (commanded,
    after the output limit)].
    """
    for a in range(2):
        err = abs(ref[a] - pos_n[a])
        if err > summary[i, a]:
            summary[i, a] = err
        if n >= par[P_STEADY] and err > summary[i, 2 + a]:
            summary[i, 2 + a] = err
    for a in range(4):
        if abs(pos_n[a]) > summary[i, SUM_XMAX + a]:
            summary[i, SUM_XMAX + a] = abs(pos_n[a])
        if abs(u[a]) > summary[i, SUM_UMAX + a]:
            summary[i, SUM_UMAX + a] = abs(u[a])
    if record:
        _store_channels(i, n, pos_n, meas, acc, u, gains, out_ch, out_gain)


@register_jitable
def _store_channels(i, n, pos_n, meas, acc, u, gains, out_ch, out_gain):
    """Sample n of run i into the recorded channels (layout: N_CH) and gains (N_GAIN)."""
    for a in range(4):
        out_ch[a, i, n] = pos_n[a]
        out_ch[4 + a, i, n] = meas[a]
        out_ch[8 + a, i, n] = acc[a]
        out_ch[12 + a, i, n] = u[a]
    for k in range(N_GAIN):
        out_gain[k, i, n] = gains[k]


# ---- the lock-step kernel: a group of runs advanced together, one lane per run ----------
# Every state variable of a run is an array whose last axis is the lane (the run), so each
# operation of a step is a loop over the lanes that LLVM turns into SIMD instructions: the
# lanes do the same IEEE operations in the same order as run_design does for one run, so
# every run gets the bits it gets alone (tests/physics/test_lockstep.py).  Only the nominal
# model (no perturbation hooks) runs here; batch_kernel sends perturbed runs to run_design.

#: lanes of a group are a multiple of LANE_ALIGN (8 doubles: one AVX-512 register) and at
#: most GROUP_MAX (the state of 128 lanes, ~0.7 MB, stays in a core's L2 cache)
LANE_ALIGN = 8
GROUP_MAX = 128


def group_lanes(n_runs: int, n_threads: int) -> int:
    """Lanes per group of batch_kernel: at least one group per thread, a multiple of
    LANE_ALIGN and at most GROUP_MAX, as few padding lanes as that allows."""
    groups = max(min(n_threads, n_runs), -(-n_runs // GROUP_MAX), 1)
    per = -(-n_runs // groups)
    return max(-(-per // LANE_ALIGN), 1) * LANE_ALIGN


@register_jitable
def run_group(
    i0, nl, L, ref1, ref2, refy, noise, noise_of, par, c0, b0, out_ch, out_th, out_gain,
    summary, status, record,
):
    """Runs ``i0 .. i0 + nl - 1`` (``nl <= L``) of the batch in lock-step, lane l = run i0 + l.

    The model and the order of every operation are run_design's with ``pp[PP_ON] == 0``;
    lanes past ``nl`` repeat the last run and are never written.  A run that diverges stops
    being written (its lane keeps computing); the group stops when all its runs have.
    The summaries and divergence checks run over the lanes; only the writes into
    ``theta_hat`` and the recorded channels go run by run.
    """
    n_steps = ref1.shape[1]
    dt = par[P_DT]
    frbf = par[P_FRBF] > 0.5
    lam, sout, fmax = par[P_LAM], par[P_SOUT], par[P_FMAX]
    eta, mom, bmin = par[P_ETA], par[P_MOM], par[P_BMIN]
    coef = np.empty((4, 3))
    for a in range(4):
        coef[a, 0], coef[a, 1], coef[a, 2] = zoh_coefficients(par[P_K + a], dt)
    row = np.empty(L, dtype=np.int64)
    src = np.empty(L, dtype=np.int64)
    for l in range(L):
        row[l] = i0 + min(l, nl - 1)
        src[l] = noise_of[row[l]]
    pos = np.zeros((4, L))
    vel = np.zeros((4, L))
    meas = np.zeros((4, L))
    meas_prev = np.zeros((4, L))
    pos_n = np.zeros((4, L))
    u = np.zeros((4, L))
    e = np.zeros((4, L))
    e1 = np.zeros((4, L))
    e2 = np.zeros((4, L))
    dfilt = np.zeros((4, L))
    gains = np.empty((N_GAIN, L))
    for a in range(2):
        for m in range(3):
            for l in range(L):
                gains[3 * a + m, l] = par[P_XGAIN + m]
    c = np.empty((2, 2, N_MF, L))
    b = np.empty((2, 2, N_MF, L))
    for t in range(2):
        for k in range(2):
            for j in range(N_MF):
                for l in range(L):
                    c[t, k, j, l] = c0[j]
                    b[t, k, j, l] = b0
    w = np.zeros((2, 3, N_RULE, L))
    dw = np.zeros((2, 3, N_RULE, L))
    dc = np.zeros((2, 2, N_MF, L))
    db = np.zeros((2, 2, N_MF, L))
    f2 = np.empty((2, N_MF, L))
    f3 = np.empty((N_RULE, L))
    f4 = np.empty((3, L))
    q = np.empty((N_RULE, L))
    g = np.empty((3, L))
    msum = np.empty((2, N_MF, L))
    x = np.empty((2, L))
    theta = np.zeros((N_THETA, L))
    P = np.zeros((N_THETA, N_THETA, L))
    for k in range(N_THETA):
        for l in range(L):
            P[k, k, l] = par[P_P0] * par[P_MASK + k]
    psi = np.empty((N_THETA, L))
    ppsi = np.empty((N_THETA, L))
    den = np.empty(L)
    err = np.empty(L)
    acc = np.empty((4, L))
    fb = np.empty((4, L))
    nz = np.empty((14, L))
    ref = np.zeros((4, L))
    psi_scale = np.array([par[P_SX], par[P_SX], par[P_SY], par[P_SY], 1.0])
    # one run's values for _store_channels (scalar layout)
    pos_1 = np.empty(4)
    meas_1 = np.empty(4)
    acc_1 = np.empty(4)
    u_1 = np.empty(4)
    gains_1 = np.empty(N_GAIN)
    code = np.zeros(L, dtype=np.int64)
    last = np.full(L, n_steps - 1, dtype=np.int64)
    live = np.zeros(L, dtype=np.bool_)  # the run is still written (not diverged, not padding)
    live[:nl] = True
    n_alive = nl
    cd = np.zeros(L, dtype=np.int64)  # this step's non-finite code, and the bound's
    out = np.zeros(L, dtype=np.int64)
    th = np.empty((N_THETA, L))  # this step's estimates in physical units
    sm = np.zeros((N_SUM, L))  # the summaries (_record's columns), from the batch's
    for l in range(nl):
        for k in range(N_SUM):
            sm[k, l] = summary[row[l], k]
    moves_y = refy.shape[0] == ref1.shape[0] and refy.shape[2] == n_steps  # run_design's
    for n in range(n_steps):
        for l in range(L):
            ref[0, l] = ref1[row[l], n]
            ref[1, l] = ref2[row[l], n]
        if moves_y:
            for l in range(L):
                ref[2, l] = refy[row[l], 0, n]
                ref[3, l] = refy[row[l], 1, n]
        for ch in range(14):
            for l in range(L):
                nz[ch, l] = noise[src[l], ch, n]
        for a in range(4):
            for l in range(L):
                meas_prev[a, l] = meas[a, l]
                meas[a, l] = pos[a, l] + nz[a, l]
                e[a, l] = ref[a, l] - meas[a, l]
        for a in range(4):
            if a < 2 and frbf:
                _frbf_pid_lanes(
                    L, e[a], e1[a], e2[a], u[a], meas[a], meas_prev[a], c[a], b[a], w[a],
                    dc[a], db[a], dw[a], f2, f3, f4, q, g, msum, x, gains, 3 * a, par, dt,
                    eta, mom, bmin,
                )
            elif a < 2:
                kp, ki, kd = par[P_XGAIN], par[P_XGAIN + 1], par[P_XGAIN + 2]
                for l in range(L):
                    u[a, l] = pid_increment(e[a, l], e1[a, l], e2[a, l], u[a, l], kp, ki, kd,
                                            fmax)
            elif par[P_YFILT] > 0.0:
                kp, ki, kd, pole = par[P_YGAIN], par[P_YGAIN + 1], par[P_YGAIN + 2], par[P_YFILT]
                for l in range(L):
                    u[a, l], dfilt[a, l] = filtered_pid_increment(
                        e[a, l], e1[a, l], u[a, l], dfilt[a, l], kp, ki, kd, pole, fmax)
            else:
                kp, ki, kd = par[P_YGAIN], par[P_YGAIN + 1], par[P_YGAIN + 2]
                for l in range(L):
                    u[a, l] = pid_increment(e[a, l], e1[a, l], e2[a, l], u[a, l], kp, ki, kd,
                                            fmax)
            for l in range(L):
                e2[a, l] = e1[a, l]
                e1[a, l] = e[a, l]
        for l in range(L):
            fbx = par[P_FB] + nz[12, l]
            fby = par[P_FB + 1] + nz[13, l]
            fb[0, l] = par[P_WSA] * fbx + par[P_WSA + 1] * fby
            fb[2, l] = par[P_WSA + 2] * fbx + par[P_WSA + 3] * fby
            fb[1, l] = par[P_WSB] * fbx + par[P_WSB + 1] * fby
            fb[3, l] = par[P_WSB + 2] * fbx + par[P_WSB + 3] * fby
            err[l] = 0.0  # y_reg of run_design
        for a in range(4):
            ka, kc, fd, scale = par[P_K + a], par[P_KC + a], par[P_FD + a], psi_scale[a]
            c0a, c1a, c2a = coef[a, 0], coef[a, 1], coef[a, 2]
            for l in range(L):
                pos_n[a, l] = pos[a, l]
                applied = u[a, l] + nz[8 + a, l] + fd - fb[a, l]
                acc[a, l] = ka * pos[a, l] + applied + nz[4 + a, l]  # r'' + N_acc
                err[l] += kc * (acc[a, l] - u[a, l])  # Eqs. 10-15
                psi[a, l] = kc * meas[a, l] / scale
                p, v = pos[a, l], vel[a, l]
                pos[a, l] = c0a * p + c1a * v + c2a * applied
                vel[a, l] = ka * c1a * p + c0a * v + c1a * applied
        for l in range(L):
            psi[4, l] = 1.0
            err[l] = err[l] / sout
        _rls_lanes(L, theta, P, psi, err, lam, ppsi, den)
        # the summaries of _record (same columns, same comparisons), over the lanes still
        # written; then the divergence codes of run_design in the same precedence
        steady = n >= par[P_STEADY]
        for a in range(2):
            for l in range(L):
                v = abs(ref[a, l] - pos_n[a, l])
                if live[l] and v > sm[a, l]:
                    sm[a, l] = v
                if steady and live[l] and v > sm[2 + a, l]:
                    sm[2 + a, l] = v
        for a in range(4):
            for l in range(L):
                v = abs(pos_n[a, l])
                if live[l] and v > sm[SUM_XMAX + a, l]:
                    sm[SUM_XMAX + a, l] = v
                v = abs(u[a, l])
                if live[l] and v > sm[SUM_UMAX + a, l]:
                    sm[SUM_UMAX + a, l] = v
        for l in range(L):
            cd[l] = OK
            out[l] = OK
        for a in range(4):
            for l in range(L):
                if not math.isfinite(u[a, l]):
                    cd[l] = BAD_FORCE
        for k in range(N_THETA):
            if par[P_MASK + k] > 0.5:
                for l in range(L):
                    th[k, l] = theta[k, l] * sout / psi_scale[k]
                    if not math.isfinite(th[k, l]):
                        cd[l] = BAD_ESTIMATE
            else:
                for l in range(L):
                    th[k, l] = math.nan  # not identified (SimulationConfig.rls_columns)
        for a in range(3, -1, -1):  # the first axis out of the bound names the code
            for l in range(L):
                if not (abs(pos[a, l]) <= par[P_BOUND]):  # also catches NaN
                    out[l] = OUT_X1 + a
        # per run (scalar): the estimates into theta_hat, the records, a divergence
        for l in range(nl):
            if not live[l]:
                continue
            i = row[l]
            for k in range(N_THETA):
                out_th[i, n, k] = th[k, l]
            if record:
                for a in range(4):
                    pos_1[a] = pos_n[a, l]
                    meas_1[a] = meas[a, l]
                    acc_1[a] = acc[a, l]
                    u_1[a] = u[a, l]
                for k in range(N_GAIN):
                    gains_1[k] = gains[k, l]
                _store_channels(i, n, pos_1, meas_1, acc_1, u_1, gains_1, out_ch, out_gain)
            c_l = cd[l] if cd[l] != OK else out[l]
            if c_l != OK:
                code[l] = c_l
                last[l] = n
                live[l] = False
                n_alive -= 1
        if n_alive == 0:
            break
    for l in range(nl):
        for k in range(N_SUM):
            summary[row[l], k] = sm[k, l]
        end_run(row[l], code[l], last[l], par, out_th, out_ch, out_gain, status, record)


@register_jitable
def _frbf_pid_lanes(
    L, e, e1, e2, u, y, y_prev, c, b, w, dc, db, dw, f2, f3, f4, q, g, msum, x, gains, at,
    par, dt, eta, mom, bmin,
):
    """_frbf_pid_axis over the lanes: the same operations in the same order per lane.

    ``e, e1, e2, u, y, y_prev`` (L,); ``c, b, dc, db`` (2, N_MF, L); ``w, dw`` (3, N_RULE,
    L); work arrays with the lane last.  Writes ``u`` and ``gains[at:at + 3]``.
    """
    for l in range(L):
        x[0, l], x[1, l] = frbf_inputs(e[l], e1[l], par, dt)
    # Eq. 23: the exponent first, then libm's exp in a loop of its own (a call per lane)
    for i in range(2):
        for j in range(N_MF):
            for l in range(L):
                d = x[i, l] - c[i, j, l]
                f2[i, j, l] = -d * d / (b[i, j, l] * b[i, j, l])
            for l in range(L):
                f2[i, j, l] = math.exp(f2[i, j, l])
    for m in range(3):
        for l in range(L):
            f4[m, l] = 0.0
    # Eqs. 24-25 in one pass over the rules (each of the three sums in the order r = 0..48)
    for j1 in range(N_MF):
        for j2 in range(N_MF):
            r = j1 * N_MF + j2
            for l in range(L):
                f = f2[0, j1, l] * f2[1, j2, l]
                f3[r, l] = f
                f4[0, l] += w[0, r, l] * f
                f4[1, l] += w[1, r, l] * f
                f4[2, l] += w[2, r, l] * f
    for m in range(3):
        for l in range(L):
            gains[at + m, l] = frbf_gain(m, f4[m, l], par)
    fmax = par[P_FMAX]
    for l in range(L):
        un = pid_increment(e[l], e1[l], e2[l], u[l], gains[at, l], gains[at + 1, l],
                           gains[at + 2, l], fmax)
        g[0, l], g[1, l], g[2, l] = frbf_gradient(
            e[l], e1[l], e2[l], un, u[l], y[l] - y_prev[l], x[0, l], f4[0, l], f4[1, l],
            f4[2, l], par)
        u[l] = un
    # Eqs. 26-27 in one pass over the rules (frbf_learn's operations and sums' orders per
    # lane): dE/df3 with the weights before the update, the weights' steps, and the sums
    # per membership (rule j1 7 + j2 adds to membership j1 of x1 and j2 of x2, in the
    # order of the other index)
    for i in range(2):
        for j in range(N_MF):
            for l in range(L):
                msum[i, j, l] = 0.0
    for m in range(3):
        for l in range(L):
            q[m, l] = -eta * g[m, l]  # q's first rows: the factors -eta dE/df4_m
    for j1 in range(N_MF):
        for j2 in range(N_MF):
            r = j1 * N_MF + j2
            for l in range(L):
                f = f3[r, l]
                s = (g[0, l] * w[0, r, l] + g[1, l] * w[1, r, l] + g[2, l] * w[2, r, l]) * f
                msum[0, j1, l] += s
                msum[1, j2, l] += s
                step = q[0, l] * f + mom * dw[0, r, l]
                w[0, r, l] += step
                dw[0, r, l] = step
                step = q[1, l] * f + mom * dw[1, r, l]
                w[1, r, l] += step
                dw[1, r, l] = step
                step = q[2, l] * f + mom * dw[2, r, l]
                w[2, r, l] += step
                dw[2, r, l] = step
    for i in range(2):
        for j in range(N_MF):
            for l in range(L):
                c[i, j, l], dc[i, j, l], b[i, j, l], db[i, j, l] = membership_step(
                    x[i, l], msum[i, j, l], c[i, j, l], b[i, j, l], dc[i, j, l],
                    db[i, j, l], eta, mom, bmin)


@register_jitable
def _rls_lanes(L, theta, P, psi, y, lam, ppsi, den):
    """rls_update over the lanes (Eq. 16; the same operations in the same order per lane).

    ``theta, psi, ppsi`` (p, L), ``P`` (p, p, L), ``y, den`` (L,); ``y`` is overwritten
    with the prediction error.
    """
    n = theta.shape[0]
    for l in range(L):
        den[l] = lam
    for i in range(n):
        for l in range(L):
            ppsi[i, l] = 0.0
        for j in range(n):
            for l in range(L):
                ppsi[i, l] += P[i, j, l] * psi[j, l]
        for l in range(L):
            den[l] += psi[i, l] * ppsi[i, l]
            y[l] -= psi[i, l] * theta[i, l]
    for i in range(n):
        for l in range(L):
            theta[i, l] += ppsi[i, l] / den[l] * y[l]
    for i in range(n):
        for j in range(n):
            for l in range(L):
                P[i, j, l] = (P[i, j, l] - ppsi[i, l] * ppsi[j, l] / den[l]) / lam


@nb.njit(parallel=True, cache=True, error_model="numpy")
def batch_kernel(
    ref1, ref2, refy, noise, noise_of, par, c0, b0, out_ch, out_th, out_gain, summary,
    status, record, pp, ps, lanes,
):
    """All runs of a batch, in parallel over groups of ``lanes`` runs in lock-step (run_group).

    ``noise`` (S, 14, N) holds S noise realisations and run ``i`` runs with
    ``noise[noise_of[i]]``: designs x seeds in one launch, each row bit-identical to a
    run of that design alone with that seed.  With perturbations (``pp[PP_ON]``) every
    run goes through run_design, one run per thread iteration.
    ``error_model="numpy"``: a division by zero gives inf/NaN (caught as a divergence)
    instead of raising, so the lane loops have no exits and vectorise.
    """
    n_runs = ref1.shape[0]
    if pp[PP_ON] > 0.5:
        for i in nb.prange(n_runs):
            run_design(
                i, ref1, ref2, refy, noise[noise_of[i]], par, c0, b0, out_ch, out_th,
                out_gain, summary, status, record, pp, ps,
            )
        return
    groups = -(-n_runs // lanes)
    for gi in nb.prange(groups):
        i0 = gi * lanes
        nl = min(lanes, n_runs - i0)
        # the last group only as wide as its runs need (a multiple of LANE_ALIGN): with two
        # threads, 100 runs are 56 + 48 lanes, not 2 x 56 (12 padded lanes computed)
        run_group(
            i0, nl, -(-nl // LANE_ALIGN) * LANE_ALIGN, ref1, ref2, refy, noise, noise_of,
            par, c0, b0, out_ch, out_th, out_gain, summary, status, record,
        )


@nb.njit(parallel=True, cache=True)
def rls_covariance_kernel(psi, lam, p0, idx, out):
    """Eq. 16's covariance recursion alone: ``out[i, n, j] = P_n[idx[j], idx[j]]``.

    ``psi`` (B, N, p) scaled regressors, ``p0`` (p, p) the initial P.  ``P_n`` does not
    depend on the measured outputs, so :func:`rls_update` runs on ``y = 0``; it is the
    very recursion of the closed loop, so ``sigma_e^2 P_n`` is the estimate's covariance
    on the same regressors (``tmopt.physics.information``).
    """
    n_par = psi.shape[2]
    for i in nb.prange(psi.shape[0]):
        theta = np.zeros(n_par)
        P = p0.copy()
        ppsi = np.empty(n_par)
        for n in range(psi.shape[1]):
            rls_update(theta, P, psi[i, n], 0.0, lam, ppsi)
            for j in range(idx.shape[0]):
                out[i, n, j] = P[idx[j], idx[j]]


@nb.njit(parallel=True, cache=True)
def rls_batch_kernel(y, psi, lam, p0, theta0, out):
    """Eq. 16 over a batch: ``y`` (B, N), ``psi`` (B, N, p) -> ``out`` (B, N, p)."""
    n_par = psi.shape[2]
    for i in nb.prange(y.shape[0]):
        theta = theta0.copy()
        P = p0.copy()
        ppsi = np.empty(n_par)
        for n in range(y.shape[1]):
            rls_update(theta, P, psi[i, n], y[i, n], lam, ppsi)
            out[i, n] = theta
