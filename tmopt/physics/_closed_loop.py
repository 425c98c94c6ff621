"""The closed loop of one design, step by step, and its compiled batch driver.

Every step function here is ``register_jitable``: numba compiles it into the batched
kernel, while a plain Python call runs the very same source in the interpreter.  The
per-design reference loop of the benchmark (``run_design`` called from Python) is hence
the same model, line for line, as the compiled batch.  All compiled code lives in this one
file because numba's on-disk cache only watches the file of the cached function.

Units are SI per unit mass throughout: positions m, forces m s^-2, stiffness s^-2.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba.extending import register_jitable

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
N_PAR = 45

N_CH = 16  # recorded channels: x (4), x measured (4), acc measured (4), force commanded (4)
N_THETA = 5
N_MF = 7  # Gaussian memberships per input
N_RULE = N_MF * N_MF

# divergence status codes (status[:, 0]); status[:, 1] is the sample index
OK, OUT_X1, OUT_X2, OUT_Y1, OUT_Y2, BAD_FORCE, BAD_ESTIMATE = 0, 1, 2, 3, 4, 5, 6


@register_jitable
def zoh_coefficients(k, h):
    """Exact ZOH coefficients (C, S, G) of ``r'' = k r + a`` (see dynamics.zoh_coefficients)."""
    z = k * h * h
    if abs(z) < 0.1:
        # even power series in z: no cancellation in cosh - 1 for tiny stiffness
        c, s, g = 0.0, 0.0, 0.0
        term = 1.0
        for n in range(12):
            c += term
            term_s = term / (2 * n + 1)
            s += term_s
            g += term_s / (2 * n + 2)
            term = term * z / ((2 * n + 1) * (2 * n + 2))
        return c, s * h, g * h * h
    w = math.sqrt(abs(k))
    if k > 0:
        c = math.cosh(w * h)
        s = math.sinh(w * h) / w
    else:
        c = math.cos(w * h)
        s = math.sin(w * h) / w
    return c, s, (c - 1.0) / k


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
    for m in range(3):
        s = 0.0
        for r in range(N_RULE):
            s += w[m, r] * f3[r]
        f4[m] = s


@register_jitable
def frbf_learn(x1, x2, g, c, b, w, dc, db, dw, f3, q, eta, mom, bmin):
    """Eqs. 26-27: one gradient-descent-with-momentum step on ``w``, ``c`` and ``b``.

    ``g[m] = dE/df4_m`` (already chained through the PID and the plant-Jacobian sign).
    Every parameter moves by ``-eta dE/dp + mom (p_{n-1} - p_{n-2})``; ``dc, db, dw`` hold
    the previous moves.  Widths are kept >= ``bmin`` so the memberships stay defined.
    """
    for r in range(N_RULE):  # dE/df3_r with the weights before the update
        q[r] = (g[0] * w[0, r] + g[1] * w[1, r] + g[2] * w[2, r]) * f3[r]
    for m in range(3):
        for r in range(N_RULE):
            step = -eta * g[m] * f3[r] + mom * dw[m, r]
            w[m, r] += step
            dw[m, r] = step
    for j in range(N_MF):
        s0 = 0.0  # rules whose first-input membership is j
        s1 = 0.0  # rules whose second-input membership is j
        for k in range(N_MF):
            s0 += q[j * N_MF + k]
            s1 += q[k * N_MF + j]
        _learn_membership(0, j, x1, s0, c, b, dc, db, eta, mom, bmin)
        _learn_membership(1, j, x2, s1, c, b, dc, db, eta, mom, bmin)


@register_jitable
def _learn_membership(i, j, x, s, c, b, dc, db, eta, mom, bmin):
    """Centre/width step for one membership; ``s = sum over its rules of dE/df3 f3``."""
    d = x - c[i, j]
    bb = b[i, j]
    grad_c = s * 2.0 * d / (bb * bb)
    grad_b = s * 2.0 * d * d / (bb * bb * bb)
    step_c = -eta * grad_c + mom * dc[i, j]
    step_b = -eta * grad_b + mom * db[i, j]
    c[i, j] += step_c
    dc[i, j] = step_c
    b[i, j] = max(bb + step_b, bmin)
    db[i, j] = b[i, j] - bb


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
def run_design(i, ref1, ref2, noise, par, c0, b0, out_ch, out_th, summary, status, record):
    """Simulate design ``i`` for ``ref1.shape[1]`` samples and write its outputs.

    One sample n: measure (+N_m), control (FRBF-PID or PID on x, PID on y), apply the
    commanded force + N_ele + f_D - f_B (f_B^s rotated into frames a and b), measure the
    acceleration at t_n (+N_acc), form the regression of Eqs. 10-15, update the RLS, and
    advance the state exactly to t_{n+1}.  On divergence (|r| > bound, non-finite force or
    estimate) the design stops and its remaining samples hold their last values.
    """
    n_steps = ref1.shape[1]
    dt = par[P_DT]
    frbf = par[P_FRBF] > 0.5
    coef = np.empty((4, 3))
    for a in range(4):
        coef[a, 0], coef[a, 1], coef[a, 2] = zoh_coefficients(par[P_K + a], dt)
    pos = np.zeros(4)
    vel = np.zeros(4)
    meas = np.zeros(4)
    pos_n = np.zeros(4)
    u = np.zeros(4)
    e1 = np.zeros(4)
    e2 = np.zeros(4)
    ge1 = np.zeros(2)  # normalised error history of the FRBF learning
    ge2 = np.zeros(2)
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
    theta = np.zeros(N_THETA)
    P = np.zeros((N_THETA, N_THETA))
    for k in range(N_THETA):
        P[k, k] = par[P_P0]
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
        for a in range(4):
            meas[a] = pos[a] + noise[a, n]
            e = ref[a] - meas[a]
            if a < 2 and frbf:
                u[a] = _frbf_pid_axis(
                    a, e, e1[a], e2[a], u[a], ge1, ge2, c[a], b[a], w[a], dc[a], db[a],
                    dw[a], f2, f3, f4, q, g, par, dt,
                )
            elif a < 2:
                u[a] = pid_increment(
                    e, e1[a], e2[a], u[a], par[P_XGAIN], par[P_XGAIN + 1], par[P_XGAIN + 2],
                    par[P_FMAX],
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
        y_reg = 0.0
        for a in range(4):
            applied = u[a] + noise[8 + a, n] + par[P_FD + a] - fb[a]
            acc[a] = par[P_K + a] * pos[a] + applied + noise[4 + a, n]  # r'' at t_n + N_acc
            # Eqs. 10-15: y = K.(r'' - f_e) with measured r'' and commanded f_e
            y_reg += par[P_KC + a] * (acc[a] - u[a])
            psi[a] = par[P_KC + a] * meas[a] / psi_scale[a]
            # propagate this axis exactly to t_{n+1} (force held over the interval)
            p, v = pos[a], vel[a]
            pos[a] = coef[a, 0] * p + coef[a, 1] * v + coef[a, 2] * applied
            vel[a] = par[P_K + a] * coef[a, 1] * p + coef[a, 0] * v + coef[a, 1] * applied
        psi[4] = 1.0
        rls_update(theta, P, psi, y_reg / par[P_SOUT], par[P_LAM], ppsi)
        for k in range(N_THETA):
            out_th[i, n, k] = theta[k] * par[P_SOUT] / psi_scale[k]
            if not math.isfinite(out_th[i, n, k]):
                code = BAD_ESTIMATE
        _record(i, n, pos_n, meas, acc, u, par, ref, out_ch, summary, record)
        if code == OK:
            for a in range(4):
                if not (abs(pos[a]) <= par[P_BOUND]):  # also catches NaN
                    code = OUT_X1 + a
                    break
        if code != OK:
            last = n
            break
    status[i, 0] = code
    status[i, 1] = last
    if code == BAD_FORCE or code == BAD_ESTIMATE:
        # sample `last` itself is not finite: hold the one before it (zeros at n = 0)
        last -= 1
        if last < 0:
            last = 0
            for k in range(N_THETA):
                out_th[i, 0, k] = 0.0
            if record:
                for ch in range(N_CH):
                    out_ch[ch, i, 0] = 0.0
    for n in range(last + 1, n_steps):  # hold after divergence: finite, never NaN
        for k in range(N_THETA):
            out_th[i, n, k] = out_th[i, last, k]
        if record:
            for ch in range(N_CH):
                out_ch[ch, i, n] = out_ch[ch, i, last]


@register_jitable
def _frbf_pid_axis(
    a, e, e1, e2, u_prev, ge1, ge2, c, b, w, dc, db, dw, f2, f3, f4, q, g, par, dt
):
    """FRBF-PID (Sec. 3.3) on sensitive axis ``a``: gains from the network, then learning.

    Inputs are ``e / e_scale`` and ``(de/dt) / ec_scale`` clipped to the centres' range
    [-1, 1]; gains are ``base * clip(1 + f4, glo, ghi)``.  The learning step uses
    ``E = e_norm^2 / 2`` with the plant Jacobian replaced by its sign (+1).
    """
    x1 = _clip1(e / par[P_ESCALE])
    x2 = _clip1((e - e1) / dt / par[P_ECSCALE])
    frbf_forward(x1, x2, c, b, w, f2, f3, f4)
    lo, hi = par[P_GLO], par[P_GHI]
    kp = par[P_XGAIN] * min(max(1.0 + f4[0], lo), hi)
    ki = par[P_XGAIN + 1] * min(max(1.0 + f4[1], lo), hi)
    kd = par[P_XGAIN + 2] * min(max(1.0 + f4[2], lo), hi)
    u = pid_increment(e, e1, e2, u_prev, kp, ki, kd, par[P_FMAX])
    # dE/df4_m = -e * sign(dy/du) * du/dK_m * dK_m/df4_m (zero where the gain is clamped)
    xc0 = x1 - ge1[a]
    xc2 = x1 - 2.0 * ge1[a] + ge2[a]
    g[0] = -x1 * xc0 * par[P_XGAIN]
    g[1] = -x1 * x1 * par[P_XGAIN + 1]
    g[2] = -x1 * xc2 * par[P_XGAIN + 2]
    for m in range(3):
        if not (lo < 1.0 + f4[m] < hi):
            g[m] = 0.0
    frbf_learn(x1, x2, g, c, b, w, dc, db, dw, f3, q, par[P_ETA], par[P_MOM], par[P_BMIN])
    ge2[a] = ge1[a]
    ge1[a] = x1
    return u


@register_jitable
def _record(i, n, pos_n, meas, acc, u, par, ref, out_ch, summary, record):
    """Store sample n (true state at t_n) and update the tracking-error summary.

    ``summary[i]`` = [max|r1 - x1|, max|r2 - x2|, the same over n >= P_STEADY (2)], true x.
    """
    for a in range(2):
        err = abs(ref[a] - pos_n[a])
        if err > summary[i, a]:
            summary[i, a] = err
        if n >= par[P_STEADY] and err > summary[i, 2 + a]:
            summary[i, 2 + a] = err
    if record:
        for a in range(4):
            out_ch[a, i, n] = pos_n[a]
            out_ch[4 + a, i, n] = meas[a]
            out_ch[8 + a, i, n] = acc[a]
            out_ch[12 + a, i, n] = u[a]


@nb.njit(parallel=True, cache=True)
def batch_kernel(ref1, ref2, noise, par, c0, b0, out_ch, out_th, summary, status, record):
    """All designs of a batch in parallel (one design per thread iteration)."""
    for i in nb.prange(ref1.shape[0]):
        run_design(i, ref1, ref2, noise, par, c0, b0, out_ch, out_th, summary, status, record)


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
