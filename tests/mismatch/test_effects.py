"""Each catalogue effect's model recovers its own parameter from data synthesised with that
term at the level of the regression (tests the estimator, not the generator).

Injection keeps the recording physical: an extra *force* ``e`` on an axis is added to the
measured acceleration and, double-integrated (ZOH), to the displacement readout, so the
kinematic check stays consistent; readout effects change only their readout.
"""

from __future__ import annotations

import ast
import copy
import math
from pathlib import Path

import numpy as np
import pytest

import tmopt
from tmopt.mismatch.diagnose import Settings, evaluate, fit_state
from tmopt.mismatch.effects import CATALOGUE, EFFECTS, Context, Effect
from tmopt.mismatch.effects.actuation_quantisation import ActuationQuantisation
from tmopt.mismatch.effects.base import discover
from tmopt.mismatch.effects.glitch import Glitch, glitch_shape
from tmopt.mismatch.effects.rotation_coupling import rotation_series
from tmopt.mismatch.fit import (
    AXES,
    data_from_result,
    fb_projection,
    fb_projection_dphi2,
    null_basis,
)
from tmopt.physics import MultiSine, SimulationConfig, simulate

REF1 = MultiSine([[5e-5, 2e-5]], [[2 * math.pi / 300, 2 * math.pi / 70]])
REF2 = MultiSine(3e-5, 2 * math.pi / 500)
SETTINGS = Settings()


@pytest.fixture(scope="module")
def clean():
    # the round-one spacecraft acceleration: the geometry error acts through f_B
    cfg = SimulationConfig(duration=600.0, fb_bias=(1e-10, 1e-10), fb_sigma=1e-10)
    res = simulate(REF1, REF2, cfg, seed=11)
    return data_from_result(res)


K_TRUE = 1e-7  # SimulationConfig's stiffness on every axis


def add_force(d, axis: int, e: np.ndarray) -> None:
    """Extra force on one axis: the displacement it causes (ZOH double integral), and the
    measured acceleration (the force plus the stiffness acting on that displacement)."""
    h2 = d.dt**2
    x = np.zeros(d.n)
    for n in range(1, d.n - 1):
        x[n + 1] = 2 * x[n] - x[n - 1] + h2 * 0.5 * (e[n] + e[n - 1] + K_TRUE * (x[n] + x[n - 1]))
    d.acc[axis] += e + K_TRUE * x
    d.x[axis] += x


def recover(d, name: str, channel: str | None = None):
    """Fit the nominal model plus the candidate; return (coefficients, std) of its columns."""
    basis = null_basis(d.geometry)
    state = fit_state(d, basis, [], [], False, SETTINGS)
    ctx = Context(d, basis, state.eq_fit.residual, state.eq_noise)
    effect = next(e for e in CATALOGUE if e.name == name)
    cands = [c for c in effect.candidates(ctx) if channel is None or c.channel == channel]
    cand = cands[0]
    eq = cand.columns if cand.group == "equation" else []
    kin = cand.columns if cand.group == "kinematic" else []
    st = fit_state(d, basis, eq, kin, False, SETTINGS)
    fit = st.eq_fit if cand.group == "equation" else st.kin_fit
    k = len(cand.columns)
    return fit.coef[-k:], fit.std()[-k:], cand


def check(value, est, std, rel=0.05):
    """Within 4.5 sigma of the truth, and the truth well resolved (std < rel |truth|)."""
    assert abs(est - value) < 4.5 * std, (est, value, std)
    assert std < rel * abs(value), (std, value)


def test_actuation_gain(clean):
    d = copy.deepcopy(clean)
    add_force(d, 0, 3e-3 * d.force[0])
    c, s, _ = recover(d, "actuation_gain", "x1")
    check(3e-3, c[0], s[0])


@pytest.mark.parametrize("tau", [0.03, 0.1])
def test_actuation_delay(clean, tau):
    d = copy.deepcopy(clean)
    f, h = d.force[1], d.dt
    mu = tau / h  # first-order (one tap): applied - commanded = mu (f_{n-1} - f_n)
    e = np.zeros(d.n)
    e[1:] = mu * (f[:-1] - f[1:])
    add_force(d, 1, e)
    c, s, cand = recover(d, "actuation_delay", "x2")
    assert cand.derived == {"tau": ("sum", h)}
    (est, sd), = cand.physical(c, np.diag(s**2)).values()
    check(tau, est, sd)


def test_stiffness_cross_coupling(clean):
    d = copy.deepcopy(clean)
    add_force(d, 2, 1e-7 * d.x[0])
    c, s, _ = recover(d, "stiffness_cross_coupling", "y1<-x1")
    check(1e-7, c[0], s[0])


def test_cubic_stiffness(clean):
    d = copy.deepcopy(clean)
    add_force(d, 0, 50.0 * d.x[0] ** 3)
    c, s, _ = recover(d, "cubic_stiffness", "x1")
    check(50.0, c[0], s[0], rel=0.1)


def test_stiffness_drift(clean):
    d = copy.deepcopy(clean)
    add_force(d, 0, 2e-10 * d.centred_time * d.x[0])
    c, s, _ = recover(d, "stiffness_drift", "x1")
    check(2e-10, c[0], s[0], rel=0.1)


def test_bias_drift(clean):
    d = copy.deepcopy(clean)
    add_force(d, 1, 2e-14 * d.centred_time)
    c, s, _ = recover(d, "bias_drift", "x2")
    check(2e-14, c[0], s[0], rel=0.1)


def test_rotation_coupling_recovers_the_lever_arm(clean):
    d = copy.deepcopy(clean)
    t = d.centred_time
    d.omega = np.array([1e-4 * np.sin(2 * np.pi * t / 400), 2e-4 * np.cos(2 * np.pi * t / 250),
                        3e-4 + 1e-5 * np.sin(t / 30)])  # fmt: skip
    d.omega_dot = np.gradient(d.omega, d.dt, axis=1)
    extra = np.tensordot(np.array([-0.4, 0.02]), rotation_series(d), axes=(0, 0))
    for a in range(4):
        add_force(d, a, extra[a])
    c, s, _ = recover(d, "rotation_coupling")
    check(-0.4, c[0], s[0], rel=0.01)
    check(0.02, c[1], s[1], rel=0.2)


def test_rotation_needs_witnesses(clean):
    basis = null_basis(clean.geometry)
    st = fit_state(clean, basis, [], [], False, SETTINGS)
    ctx = Context(clean, basis, st.eq_fit.residual, st.eq_noise)
    assert next(e for e in CATALOGUE if e.name == "rotation_coupling").candidates(ctx) == []


def test_acceleration_readout_cross_talk_and_scale(clean):
    d = copy.deepcopy(clean)
    d.acc[2] += 1e-3 * d.acc[0]
    c, s, _ = recover(d, "sensing_cross_talk", "acc:y1<-x1")
    check(1e-3, c[0], s[0])
    d = copy.deepcopy(clean)
    d.acc[0] *= 1 + 2e-3
    c, s, cand = recover(d, "readout_scale", "acc:x1")
    (e, se), = cand.physical(c, np.diag(s**2)).values()
    check(2e-3, e, se)


def test_displacement_readout_scale_uses_the_kinematic_check(clean):
    d = copy.deepcopy(clean)
    d.x[0] *= 1 + 1e-3
    c, s, cand = recover(d, "readout_scale", "disp:x1")
    assert cand.group == "kinematic"
    check(1e-3, c[0], s[0])


def test_displacement_cross_talk(clean):
    d = copy.deepcopy(clean)
    d.x[2] += 1e-3 * clean.x[0]
    c, s, _ = recover(d, "sensing_cross_talk", "disp:y1<-x1")
    check(1e-3, c[0], s[0], rel=0.1)


def test_geometry_error(clean):
    d = copy.deepcopy(clean)
    p = fb_projection(d.geometry)
    fb = -np.linalg.pinv(p) @ (d.acc - d.force)
    extra = -5e-3 * fb_projection_dphi2(d.geometry) @ fb
    for a in range(4):
        add_force(d, a, extra[a])
    c, s, _ = recover(d, "geometry_error")
    check(5e-3, c[0], s[0], rel=0.2)


def test_glitch_is_found_where_it_is(clean):
    d = copy.deepcopy(clean)
    add_force(d, 1, 3e-11 * glitch_shape(d.time - 400.0, 4.0, "exp"))
    basis = null_basis(d.geometry)
    st = fit_state(d, basis, [], [], False, SETTINGS)
    ctx = Context(d, basis, st.eq_fit.residual, st.eq_noise)
    (cand,) = Glitch().candidates(ctx)
    assert cand.channel == "x2"
    assert abs(cand.fixed["t0_s"] - 400.0) <= 1.0
    assert 2.0 <= cand.fixed["decay_s"] <= 8.0  # width grid is a factor 2
    st = fit_state(d, basis, cand.columns, [], False, SETTINGS)
    amp, sd = st.eq_fit.coef[-1], st.eq_fit.std()[-1]
    assert abs(amp - 3e-11) < 0.25 * 3e-11 and sd < 0.1 * 3e-11


def test_a_glitch_between_samples_is_fitted_off_the_grids():
    """A loud shapelet glitch (the injection's exact interval average) starting 0.37 of a
    sample after a sample time, width 5.3 s (between the width grid's points): onset and
    width are fitted off the grids, and the kick follows.  Before (sample-grid onset,
    width grid 2^0.1): kick 2.4 % (17 sigma) off on seed 11, and the remainder's matched
    filter statistic 105 (a second glitch named; now 35); benchmark r4 on the
    independent simulator named such remainders as two or three more glitches.

    The kick's error is the width's (about 1.3x it), not the noise's (its standard error
    is 0.03-0.15 %): on 8 fresh noise draws (seeds 15-22) it is 0.1-2.4 % with the
    band-median coherence (mean 1.05 %) and 0.2-2.4 % with the regression (mean 0.91 %,
    docs/mismatch.md 9.21).  So round one's "1 % on seed 11" is not a bound for every
    draw; the check keeps its tolerances and holds them on four draws (default
    estimate: 0.25, 0.07, 0.88, 0.01 %; the regression option misses two of them, 1.2
    and 2.7 %).  On the fresh draws the onset is off by up to 0.58 of a sample and the
    width by up to 2.0 %, with either estimate."""
    from tmopt.mismatch.effects.glitch import glitch_interval_average

    cfg = SimulationConfig(duration=600.0, fb_bias=(1e-10, 1e-10), fb_sigma=1e-10)
    kick = []
    for seed in (11, 12, 13, 14):
        d = data_from_result(simulate(REF1, REF2, cfg, seed=seed))
        t0 = float(d.time[d.n // 3]) + 0.37 * d.dt
        add_force(d, 0, 1e-8 * glitch_interval_average(d.time, d.dt, t0, 5.3, "shapelet"))
        basis = null_basis(d.geometry)
        st = fit_state(d, basis, [], [], False, SETTINGS)
        ctx = Context(d, basis, st.eq_fit.residual, st.eq_noise)
        (cand,) = Glitch().candidates(ctx)
        assert cand.channel == "x1" and cand.fixed["shape"] == "shapelet"
        assert abs(cand.fixed["t0_s"] - t0) < 0.2 * d.dt, (cand.fixed["t0_s"], t0)
        assert abs(cand.fixed["decay_s"] / 5.3 - 1) < 0.02, cand.fixed["decay_s"]
        st = fit_state(d, basis, cand.columns, [], False, SETTINGS)
        kick.append(abs(st.eq_fit.coef[-1] / 1e-8 - 1))
    assert max(kick) < 0.01, kick


def test_glitch_kicks_match_lisaglitch():
    """The analytic kick of the diagnosis templates (``_kick``) against the LISA
    consortium's ``lisaglitch`` integrated shapelet (an independent implementation)."""
    from tmopt.mismatch.effects.glitch import _kick, _velocity

    t = np.linspace(100.0, 200.0, 1001)
    for kind in ("exp", "shapelet"):
        ref = _velocity(kind, t, 123.4, 5.0, None, 2.0)
        assert np.max(np.abs(_kick(t - 123.4, 5.0, kind) - ref)) < 1e-12


def test_colored_noise_is_decided_by_the_red_noise_likelihood(clean):
    """With the white noise model (round one's; ``Settings(noise="white")``) coloured noise
    is an effect decided by the Whittle likelihood ratio; with the default coloured model it
    is part of the noise model (test_colored_noise_is_untestable_with_the_coloured_model)."""
    model = Settings(noise="white")
    # 1/f force noise on x1: ASD 1e-11 m s^-2/sqrt(Hz) at 1 mHz (white floor ~6e-13)
    white = np.fft.rfft(np.random.default_rng(3).standard_normal(clean.n))
    f = np.fft.rfftfreq(clean.n, clean.dt)
    f[0] = f[1]
    asd = 1e-11 * (1e-3 / f) ** 0.5  # PSD ~ 1/f
    # unit white noise has ASD sqrt(2/fs): rescale each bin to the target ASD
    red = np.fft.irfft(white * asd * math.sqrt(clean.fs / 2), n=clean.n)
    d = copy.deepcopy(clean)
    add_force(d, 0, red)
    basis = null_basis(d.geometry)
    for data, significant in ((clean, False), (d, True)):
        st = fit_state(data, basis, [], [], False, model)
        (ev,) = [e for e in evaluate(data, basis, st, model, set())
                 if e.candidate.effect == "colored_noise"]  # fmt: skip
        assert (ev.p_holm < model.alpha) is significant, (ev.p_holm, ev.candidate.fixed)
        if significant:
            assert all(0.5 <= g <= 1.75 for g in ev.candidate.fixed["exponent"])  # 1/f: 1
    # the default (coloured) noise model holds stationary coloured noise itself: no
    # candidate, and the report says why
    st = fit_state(d, basis, [], [], False, SETTINGS)
    assert not [e for e in evaluate(d, basis, st, SETTINGS, set())
                if e.candidate.effect == "colored_noise"]  # fmt: skip
    ctx = Context(d, basis, st.eq_fit.residual, st.eq_noise)
    assert "estimated from the recording" in EFFECTS["colored_noise"].untestable(ctx)




@pytest.mark.parametrize("noise", ["white", "coloured"])
def test_quantisation_step_is_recovered(clean, noise):
    """The quantisation step search and gain, with white and with coloured equation noise
    models.  With the coloured model and main's spacecraft jitter (fb_sigma 1e-10) the x1
    gain came out 1.26 +- 0.034 while q was searched to ~1e-4 of itself; q is now settled
    on the exact sawtooth (:meth:`ActuationQuantisation._settle`)."""
    settings = Settings(noise=noise)
    d = copy.deepcopy(clean)
    q = 3e-12
    for a in range(4):
        add_force(d, a, q * np.round(d.force[a] / q) - d.force[a])
    basis = null_basis(d.geometry)
    st = fit_state(d, basis, [], [], False, settings)
    ctx = Context(d, basis, st.eq_fit.residual, st.eq_noise)
    (cand,) = ActuationQuantisation().candidates(ctx)
    assert abs(cand.fixed["q"] - q) < 0.01 * q
    st = fit_state(d, basis, cand.columns, [], False, settings)
    beta, sd = st.eq_fit.coef[-4:], st.eq_fit.std()[-4:]
    assert np.all(np.abs(beta - 1) < 4.5 * sd + 0.05), (beta, sd)


def test_every_effect_is_one_module_with_both_sides():
    # one module per effect, named after it, holding how it is made and how it is found
    assert len(CATALOGUE) >= 13 and len({e.name for e in CATALOGUE}) == len(CATALOGUE)
    for e in CATALOGUE:
        cls = type(e)
        assert cls.__module__ == f"tmopt.mismatch.effects.{e.name}", e.name
        assert cls.inject is not Effect.inject and cls.candidates is not Effect.candidates
        assert e.parameter and e.unit and e.limit > 0 and e.default_channel in e.channels
        assert e.calibration is not None and e.calibration.channel in e.channels
    assert all(e.explanation and e.needs for e in CATALOGUE)
    assert AXES == ("x1", "x2", "y1", "y2")


def test_each_effect_name_has_one_definition():
    # outside its own module no code of the package spells an effect's name (the physics
    # kernel's Perturbations slots are named after the perturbation, not the effect)
    root = Path(tmopt.__file__).parent
    names = {e.name for e in CATALOGUE}
    seen = {}
    for path in root.rglob("*.py"):
        if path.parent.name == "physics":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value in names:
                seen.setdefault(node.value, set()).add(path.relative_to(root).as_posix())
    for name in names:
        assert seen[name] == {f"mismatch/effects/{name}.py"}, (name, seen[name])


def test_non_profiled_effects_give_regressors_without_a_residual(clean):
    # what an information matrix of a planned excitation needs: columns from data alone
    basis = null_basis(clean.geometry)
    for e in CATALOGUE:
        if e.profiled:
            with pytest.raises(ValueError, match="searched on a residual"):
                e.regressors(clean, basis)
            continue
        cands = e.regressors(clean, basis)
        if e.untestable(Context(clean, basis)) is not None:  # e.g. no attitude witnesses
            assert cands == []
            continue
        assert cands and all(c.columns and c.effect == e.name for c in cands), e.name


@pytest.mark.parametrize("body, match", [
    ("class Bar(Effect):\n    name = 'bar'\n", "module's name 'foo'"),
    ("X = 1\n", "exactly one Effect"),
    ("class A(Effect):\n    name = 'foo'\n\n\nclass B(Effect):\n    name = 'foo'\n",
     "exactly one Effect"),
])  # fmt: skip
def test_the_registry_holds_one_effect_per_module_named_after_it(tmp_path, monkeypatch,
                                                                  body, match):  # fmt: skip
    name = "fx_" + tmp_path.name  # a fresh package each case (imports are cached)
    pkg = tmp_path / name
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "foo.py").write_text("from tmopt.mismatch.effects.base import Effect\n\n\n" + body)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(TypeError, match=match):
        discover(name, [str(pkg)])
