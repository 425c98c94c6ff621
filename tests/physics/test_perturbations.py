"""Perturbation hooks of the simulator: off = the model before the hooks, bit for bit;
each hook does exactly what its docstring says (checked on noise-free runs)."""

import math

import numpy as np
import pytest

from tmopt.physics import _closed_loop as cl
from tmopt.physics.dynamics import free_motion
from tmopt.physics.excitation import MultiSine
from tmopt.physics.scenario import config_at_rate
from tmopt.physics.simulator import (
    CHANNEL_NAMES,
    Perturbations,
    SimulationConfig,
    simulate,
    simulate_reference,
)

REF1 = MultiSine([[5e-5], [2e-5]], [[2 * math.pi / 300], [2 * math.pi / 100]])
REF2 = MultiSine([[3e-5], [1e-5]], 2 * math.pi / 500)
QUIET = dict(sigma_m1=0.0, sigma_m2=0.0, sigma_acc=0.0, sigma_ele=0.0, fb_sigma=0.0)

# Values of the simulator before issue 17 (commit a70ed27, controller "pid", this
# scenario): design 0 then 1, samples 17, 1234, 2999.  The hooks off, the round-one
# y-axes and all five RLS columns must give them back.  Printed with repr.
PINNED = {
    "x1_true": [1.2792304390176088e-07, 2.6433142885102356e-05, -1.00148850647651e-07,
                1.2792304390176088e-07, 2.3913525723426363e-05, -7.906688114794072e-08],
    "acc_x2": [9.977263807735565e-08, -4.64501301954741e-09, 2.885954235948557e-09,
               4.262575937330045e-08, -1.4873333108245263e-09, 1.0311193974165126e-09],
    "force_y1": [9.375031940359634e-09, 1.2837460506883824e-08, -3.431138220366704e-09,
                 9.375031940359634e-09, 1.2837460506883824e-08, -3.431138220366704e-09],
}  # fmt: skip
PINNED_THETA = [9.321697252113109e-08, -8.652553042270974e-11, 9.723602662898859e-08,
                -8.659411117127744e-11]  # fmt: skip


def _same(a, b):
    np.testing.assert_array_equal(a.channels, b.channels)
    np.testing.assert_array_equal(a.theta_hat, b.theta_hat)
    np.testing.assert_array_equal(a.max_tracking_error, b.max_tracking_error)


def test_without_perturbations_the_simulator_is_unchanged():
    # Equality to the last digit on the machine that pinned them; libm's exp/cosh may
    # differ in the last ulp elsewhere, which a stable loop keeps far below 1e-9.
    cfg = dict(duration=300.0, controller="pid", rls_columns="all", ramp_in=0.0)
    res = simulate(REF1, REF2, config_at_rate(y_axes="round1", **cfg), seed=11)
    for name, values in PINNED.items():
        got = getattr(res, name)[:, [17, 1234, 2999]].ravel()
        np.testing.assert_allclose(got, values, rtol=1e-9, atol=0, err_msg=name)
    np.testing.assert_allclose(res.theta_hat[:, -1, [0, 4]].ravel(), PINNED_THETA, rtol=1e-9)
    assert res.perturbations is None


def _neutral(n: int) -> Perturbations:
    return Perturbations(
        actuation_gain=np.zeros((4, n)), actuation_delay=(0.0,) * 4,
        actuation_step=(0.0,) * 4, stiffness_change=np.zeros((4, n)),
        stiffness_coupling=np.zeros((4, 4)), cubic_stiffness=(0.0,) * 4,
        force=np.zeros((4, n)), omega=np.zeros((3, n)), omega_dot=np.zeros((3, n)),
        readout=np.eye(4),
    )


@pytest.mark.parametrize("controller", ["frbf_pid", "pid"])
def test_neutral_perturbations_change_no_bit(controller):
    cfg = SimulationConfig(duration=200.0, controller=controller)
    base = simulate(REF1, REF2, cfg, seed=5)
    _same(base, simulate(REF1, REF2, cfg, seed=5, perturbations=Perturbations()))
    _same(base, simulate(REF1, REF2, cfg, seed=5, perturbations=_neutral(cfg.n_steps)))


def test_perturbed_compiled_batch_equals_the_python_reference():
    cfg = SimulationConfig(duration=30.0, controller="pid")
    n = cfg.n_steps
    t = np.arange(n) / cfg.sample_rate
    pert = Perturbations(
        actuation_gain=np.full((4, n), 0.01), actuation_delay=(0.25, 0.0, 0.1, 0.0),
        actuation_step=(1e-11, 0.0, 0.0, 0.0), stiffness_change=np.full((4, n), 1e-9),
        stiffness_coupling=np.full((4, 4), 1e-8), cubic_stiffness=(1e3, 0.0, 0.0, 0.0),
        force=np.full((4, n), 1e-11), omega=np.vstack([t * 0, t * 0 + 1e-6, 1e-4 + t * 0]),
        omega_dot=np.full((3, n), 1e-8), readout=np.eye(4) + 1e-3,
    )
    _same(simulate(REF1, REF2, cfg, 2, pert), simulate_reference(REF1, REF2, cfg, 2, pert))


def _quiet_run(pert, duration=120.0, **kw):
    cfg = SimulationConfig(duration=duration, controller="pid", **QUIET, **kw)
    return cfg, simulate(REF1, REF2, cfg, seed=0, perturbations=pert)


def _applied_total(cfg, res, a):
    """acc - k r: everything acting on axis a (noise-free run) -> (B, N)."""
    name = ("x1", "x2", "y1", "y2")[a]
    return getattr(res, f"acc_{name}") - cfg.theta_true[a] * getattr(res, f"{name}_true")


def _nominal_other(cfg, a):
    """f_D - f_B on axis a (constant in a noise-free run)."""
    fd = [cfg.bias_1[0], cfg.bias_2[0], cfg.bias_1[1], cfg.bias_2[1]][a]
    w = (cfg.geometry.w_sa if a in (0, 2) else cfg.geometry.w_sb)[:2, :2]
    return fd - (w @ np.asarray(cfg.fb_bias))[0 if a < 2 else 1]


def test_actuation_gain_and_quantisation_act_on_the_applied_force():
    n = 1200
    gain = np.zeros((4, n))
    gain[0, 600:] = 0.05  # a gain step at t = 60 s on x1
    cfg, res = _quiet_run(Perturbations(actuation_gain=gain, actuation_step=(0, 3e-10, 0, 0)))
    applied = _applied_total(cfg, res, 0) - _nominal_other(cfg, 0)
    np.testing.assert_allclose(applied, (1 + gain[0]) * res.force_x1, rtol=0,
                               atol=_rounding(res, 0))
    applied = _applied_total(cfg, res, 1) - _nominal_other(cfg, 1)
    np.testing.assert_allclose(applied, 3e-10 * np.floor(res.force_x2 / 3e-10 + 0.5),
                               rtol=0, atol=_rounding(res, 1))
    assert np.unique(np.round(applied / 3e-10, 6) % 1).size == 1  # on the lattice


def test_actuation_delay_applies_the_held_command_tau_later():
    tau = 0.37  # 3 samples + 0.07 s
    cfg, res = _quiet_run(Perturbations(actuation_delay=(tau, 0.0, 0.0, 0.0)))
    applied = _applied_total(cfg, res, 0) - _nominal_other(cfg, 0)
    # over [t_n, t_n + 0.07) the command of t_{n-4} acts, then that of t_{n-3}; the
    # acceleration channel reports the interval average
    u = res.force_x1
    expected = np.zeros_like(u)
    expected[:, 4:] = 0.7 * u[:, :-4] + 0.3 * u[:, 1:-3]
    expected[:, 3] = 0.3 * u[:, 0]
    np.testing.assert_allclose(applied, expected, rtol=0, atol=_rounding(res, 0))


def test_a_tiny_delay_changes_the_recording_a_tiny_bit():
    # the acceleration channel is continuous in tau (no jump from t_n+ sampling)
    _, base = _quiet_run(None)
    _, res = _quiet_run(Perturbations(actuation_delay=(1e-9, 0.0, 0.0, 0.0)))
    scale = np.abs(base.acc_x1).max()
    assert 0 < np.abs(res.acc_x1 - base.acc_x1).max() < 1e-6 * scale


@pytest.mark.parametrize("tau,lag,delta", [(0.0, 0, 0.0), (0.04, 0, 0.04), (0.1, 1, 0.0),
                                            (0.23, 2, 0.03)])  # fmt: skip
def test_split_step_is_the_exact_piecewise_solution(tau, lag, delta):
    k, dt = 3e-3, 0.1
    par = np.zeros(cl.N_PAR)
    par[cl.P_K : cl.P_K + 4] = k
    pp = np.zeros(cl.N_PP)
    pp[cl.PP_TAU : cl.PP_TAU + 4] = tau
    lags, split = np.zeros(4, dtype=np.int64), np.zeros(4)
    c1, c2 = np.empty((4, 3)), np.empty((4, 3))
    cl._delay_setup(par, pp, dt, lags, split, c1, c2)
    assert lags[0] == lag and split[0] == pytest.approx(delta, abs=1e-12)
    if delta == 0.0:
        return
    pos, vel = np.full(4, 2e-6), np.full(4, -1e-7)
    cl._zoh_advance(0, pos, vel, k, c1, 1e-9)  # older command over [t_n, t_n + delta)
    cl._zoh_advance(0, pos, vel, k, c2, -4e-9)  # newer one over the rest of the step
    r, v = free_motion(k, 2e-6, -1e-7, 1e-9, np.array([delta]))
    r, v = free_motion(k, r[0], v[0], -4e-9, np.array([dt - delta]))
    np.testing.assert_allclose([pos[0], vel[0]], [r[0], v[0]], rtol=1e-12)


def _rounding(res, a):
    """Rounding floor of extracting a small force from acc (~1e-8): 16 ulps of |acc|."""
    return 16 * np.finfo(float).eps * np.abs(res.channels[8 + a]).max()


def test_stiffness_hooks_add_the_stated_forces():
    n = 1200
    dk = np.zeros((4, n))
    dk[0] = 1e-9 * np.arange(n) / 10.0  # drift of k1xx, 1e-9 s^-3
    coupling = np.zeros((4, 4))
    coupling[2, 0] = 1e-6  # x1 into the y1 equation
    cubic = (0.0, 1e3, 0.0, 0.0)
    cfg, res = _quiet_run(Perturbations(stiffness_change=dk, stiffness_coupling=coupling,
                                        cubic_stiffness=cubic))
    extra = [_applied_total(cfg, res, a) - _nominal_other(cfg, a) - res.channels[12 + a]
             for a in range(4)]
    expected = [dk[0] * res.x1_true, 1e3 * res.x2_true**3, 1e-6 * res.x1_true, 0 * res.y2]
    for a in range(4):
        assert np.abs(expected[a]).max() > 1e4 * _rounding(res, a) or a == 3
        np.testing.assert_allclose(extra[a], expected[a], rtol=0, atol=_rounding(res, a))


def test_force_series_and_readout_matrix():
    n = 1200
    force = np.zeros((4, n))
    force[2, 300:320] = 4e-10
    readout = np.eye(4)
    readout[0, 0] += 1e-3  # x1 scale error
    readout[1, 0] = 0.02  # x2 picks up 2 % of x1
    cfg, res = _quiet_run(Perturbations(force=force, readout=readout))
    extra = _applied_total(cfg, res, 2) - _nominal_other(cfg, 2) - res.force_y1
    np.testing.assert_allclose(extra, np.broadcast_to(force[2], extra.shape), rtol=0,
                               atol=_rounding(res, 2))
    # x_meas at t_n is the readout of the state at t_n
    np.testing.assert_allclose(res.x1, (1 + 1e-3) * res.x1_true, rtol=1e-15, atol=0)
    np.testing.assert_allclose(res.x2, res.x2_true + 0.02 * res.x1_true, rtol=1e-12, atol=1e-24)
    assert np.array_equal(res.y1, res.y1_true)


def test_rotation_terms_equal_eq1_with_numpy_cross_products():
    rng = np.random.default_rng(0)
    cfg = SimulationConfig()
    par = np.zeros(cl.N_PAR)
    par[cl.P_WSA : cl.P_WSA + 4] = cfg.geometry.w_sa[:2, :2].ravel()
    par[cl.P_WSB : cl.P_WSB + 4] = cfg.geometry.w_sb[:2, :2].ravel()
    pp = np.zeros(cl.N_PP)
    pp[cl.PP_R01 : cl.PP_R01 + 3] = cfg.geometry.r01_s
    pp[cl.PP_R02 : cl.PP_R02 + 3] = cfg.geometry.r02_s + [0.0, 0.0, 0.01]
    ps = np.zeros((cl.N_S, 1))
    ps[cl.S_OMEGA : cl.S_OMEGA + 6, 0] = rng.normal(0, 1e-3, 6)
    pos, vel = rng.normal(0, 1e-4, 4), rng.normal(0, 1e-5, 4)
    extra = np.zeros(4)
    cl._rotation_terms(0, pos, vel, par, pp, ps, 0, 2, cl.P_WSA, cl.PP_R01, extra)
    cl._rotation_terms(0, pos, vel, par, pp, ps, 1, 3, cl.P_WSB, cl.PP_R02, extra)
    w, wd = ps[cl.S_OMEGA : cl.S_OMEGA + 3, 0], ps[cl.S_OMEGA_DOT : cl.S_OMEGA_DOT + 3, 0]
    for (ax, ay), wmat, r0 in (((0, 2), cfg.geometry.w_sa, pp[54:57]),
                               ((1, 3), cfg.geometry.w_sb, pp[57:60])):  # fmt: skip
        rho = r0 + wmat.T @ [pos[ax], pos[ay], 0.0]
        rho_dot = wmat.T @ [vel[ax], vel[ay], 0.0]
        acc = np.cross(rho, wd) + 2 * np.cross(rho_dot, w) + np.cross(w, np.cross(rho, w))
        np.testing.assert_allclose(extra[[ax, ay]], (wmat @ acc)[:2], rtol=1e-12, atol=1e-25)


def _eq1_terms(cfg, omega, omega_dot, pos=None, vel=None):
    """Eq. 1's rotation terms in the TM frames (4, N), numpy cross products.

    ``pos``/``vel`` (4, N): TM displacements/velocities; None = TMs at their nominal centres.
    """
    n = omega.shape[1]
    pos = np.zeros((4, n)) if pos is None else pos
    vel = np.zeros((4, n)) if vel is None else vel
    out = np.zeros((4, n))
    geo = cfg.geometry
    for (ax, ay), wmat, r0 in (((0, 2), geo.w_sa, geo.r01_s), ((1, 3), geo.w_sb, geo.r02_s)):
        rho = r0[:, None] + wmat.T @ np.vstack([pos[[ax, ay]], np.zeros(n)])
        rho_dot = wmat.T @ np.vstack([vel[[ax, ay]], np.zeros(n)])
        acc = (np.cross(rho, omega_dot, axis=0) + 2 * np.cross(rho_dot, omega, axis=0)
               + np.cross(omega, np.cross(rho, omega, axis=0), axis=0))  # fmt: skip
        out[[ax, ay]] = (wmat @ acc)[:2]
    return out


def test_rotation_in_the_closed_loop_and_the_k_combination():
    # Sec. 2.2: K (Eq. 11) removes the lever-arm Euler term r12 x w' (w' along z) but keeps
    # the centrifugal w x (r12 x w) along x_s, which Eq. 8 carries as sin(phi1 - phi2)[.]_xs.
    n = 1200
    t = np.arange(n) / 10.0
    omega, wdot = np.zeros((3, n)), np.zeros((3, n))
    wdot[2] = 1e-8 * np.sin(2 * math.pi * t / 60)
    omega[2] = 1e-5 + 1e-8 * 60 / (2 * math.pi) * (1 - np.cos(2 * math.pi * t / 60))
    cfg, res = _quiet_run(Perturbations(omega=omega, omega_dot=wdot))
    extra = np.stack([_applied_total(cfg, res, a) - _nominal_other(cfg, a) - res.channels[12 + a]
                      for a in range(4)])  # fmt: skip
    h = 0.1
    for i in range(2):
        pos = res.channels[:4, i]
        vel = np.gradient(pos, h, axis=1)  # central differences: error <= h^2 max|jerk| / 6
        jerk = np.abs(np.diff(pos, 3, axis=1)).max() / h**3
        # the velocity estimate enters only through the Coriolis term 2 rho' x w
        bound = 2 * np.abs(omega).max() * h**2 * jerk / 6 + 1e-12 * np.abs(extra).max()
        full = _eq1_terms(cfg, omega, wdot, pos, vel)
        np.testing.assert_allclose(extra[:, i, 1:-1], full[:, 1:-1], rtol=0, atol=4 * bound)
    k = cfg.coefficients
    euler = _eq1_terms(cfg, 0 * omega, wdot)
    assert np.abs(euler[0]).max() > 1e-9  # 0.2 m x 1e-8 rad s^-2 on each TM ...
    assert np.abs(k @ euler).max() < 1e-13 * np.abs(euler).max()  # ... cancelled by K
    geo = cfg.geometry  # ... while the centrifugal part survives
    centrifugal = _eq1_terms(cfg, omega, 0 * wdot)
    along_xs = omega[2] ** 2 * geo.r12_s[0]  # (w x (r12 x w))_xs = w^2 r12_x for w along z
    np.testing.assert_allclose(k @ centrifugal, -math.sin(geo.phi1 - geo.phi2) * along_xs,
                               rtol=1e-12)


def test_bad_perturbations_raise_naming_the_field():
    with pytest.raises(ValueError, match="actuation_delay"):
        Perturbations(actuation_delay=(-0.1, 0, 0, 0))
    with pytest.raises(ValueError, match="readout"):
        Perturbations(readout=np.eye(3))
    with pytest.raises(ValueError, match="stiffness_coupling"):
        Perturbations(stiffness_coupling=np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match="omega"):
        Perturbations(omega=np.zeros((3, 10)))
    cfg = SimulationConfig(duration=10.0)
    with pytest.raises(ValueError, match="force must have shape"):
        simulate(REF1, REF2, cfg, perturbations=Perturbations(force=np.zeros((4, 99))))
    with pytest.raises(ValueError, match="actuation_delay must be in"):
        simulate(REF1, REF2, cfg, perturbations=Perturbations(actuation_delay=(10.0, 0, 0, 0)))
    with pytest.raises(ValueError, match="Perturbations"):
        simulate(REF1, REF2, cfg, perturbations={"force": 1})
    assert CHANNEL_NAMES[12] == "force_x1"  # the helper above relies on this order
