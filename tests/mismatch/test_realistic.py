"""Flight-like recordings (issue 26): scenario ranges, both simulators, gaps, glitches from
lisaglitch, out-of-catalogue effects, and the independence of the foreign simulator."""

from __future__ import annotations

import ast
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tmopt.mismatch import foreign
from tmopt.mismatch.effects import Injection
from tmopt.mismatch.effects.glitch import glitch_interval_average
from tmopt.mismatch.fit import (
    ACC_CONVENTIONS,
    data_from_recording,
    kinematic_coefficients,
    kinematic_target,
)
from tmopt.mismatch.generate import _psd_on_grid, matched_snr, residual_families, whitened_power
from tmopt.mismatch.realistic import (
    ACC_BUDGET,
    DISP_BUDGET,
    OUT_OF_CATALOGUE,
    Background,
    _clean_cache,
    draw_glitches,
    draw_scenario,
    make_ooc,
    realistic_recording,
    scale_to_snr,
)
from tmopt.physics.recording import AXES, Recording

QUIET = Background({k: 1e-9 for k in ("m1", "m2", "acc", "ele", "fb")}, 1e-9, 1e9, 1e-9, 1.0)


def short(seed: int, backend: str = "kernel", **kw):
    """A short scenario (fast): 1200 s at 2 Hz, its other draws kept."""
    return replace(draw_scenario(seed, backend), duration=1200.0, sample_rate=2.0, **kw)


def test_scenarios_stay_within_the_issue_ranges_and_eq_20():
    for seed in range(60):
        for backend in ("kernel", "foreign"):
            sc = draw_scenario(seed, backend)
            assert 1200 <= sc.duration <= 3600 and 2 <= sc.sample_rate <= 10
            assert all(-2e-6 <= k <= 2e-6 for k in sc.stiffness)
            assert all(0.5 <= v <= 3.0 for v in sc.background.factors.values())
            assert 1 <= len(sc.tones[0]) <= 3 and 1 <= len(sc.tones[1]) <= 3
            if backend == "kernel":  # the project's kernel has no y reference
                assert sc.tones[2] == () and sc.tones[3] == ()
            for tm in sc.tones:
                acc = sum(a * (2 * math.pi / p) ** 2 for a, p, _ in tm)
                assert acc <= ACC_BUDGET * (1 + 1e-9)  # Eq. 20: sum A w^2 <= alpha1 F_max
                assert 2 * sum(a for a, _, _ in tm) <= DISP_BUDGET * (1 + 1e-9)  # |x| <= alpha2 D
            for t0, t1, kind in sc.gaps:
                assert 0 <= t0 < t1 <= sc.duration and kind in ("nan", "nan_some", "drop")


@pytest.mark.parametrize("backend", ["kernel", "foreign"])
def test_a_realistic_recording_has_gaps_colour_and_its_truth(backend):
    sc = short(3, backend, gaps=((300.0, 330.0, "nan"), (700.0, 710.0, "drop")))
    sc = replace(sc, glitches=draw_glitches(3, sc, 2))
    rec, truth = realistic_recording(sc, seed=3, backend=backend)
    assert len(rec.gaps) == 2 and {g.inserted for g in rec.gaps} == {False, True}
    assert truth["samples"]["valid"] < truth["samples"]["grid"] == rec.n_samples
    assert [e["name"] for e in truth["effects"]] == ["glitch", "glitch"]
    assert all(e["background"] for e in truth["effects"])
    # the readout is red (1/f corner): what the corner adds to a readout (the same record
    # with the corner moved out of the band subtracted) is red
    white_sc = replace(sc, background=replace(sc.background, readout_f_c=1e-9))
    white, _ = realistic_recording(white_sc, seed=3, backend=backend)
    for ch in ("x1", "y1"):
        x = (rec[ch] - white[ch])[rec.valid][:1000]
        per = np.abs(np.fft.rfft(x - x.mean())) ** 2
        assert per[1:6].mean() > 3 * np.median(per[100:]), ch
    d = data_from_recording(rec)
    assert d.usage["samples_used"] <= truth["samples"]["valid"] and d.usage["gaps"] == 2


def test_lisaglitch_shapes_keep_the_kick_exact():
    t = np.arange(6000) / 10.0
    for shape, rise in (("shapelet", None), ("exp", None), ("one_sided", 1.0), ("two_sided", 1.0)):
        avg = glitch_interval_average(t, 0.1, 100.0, 8.0, shape, rise, 2.0)
        assert avg.sum() * 0.1 == pytest.approx(1.0, rel=1e-6)  # unit kick: dv exactly
        assert np.all(avg[t + 0.1 <= 100.0] == 0)
    two = glitch_interval_average(t, 0.1, 100.0, 8.0, "two_sided", 1.0, 2.0)
    assert two.min() < 0 < two.max()  # the opposite lobe of a two-sided glitch


@pytest.mark.parametrize("name", sorted(OUT_OF_CATALOGUE))
def test_every_out_of_catalogue_effect_changes_the_recording(name):
    sc = replace(short(5), gaps=())
    clean, _ = realistic_recording(sc, seed=5)
    o = make_ooc(name, OUT_OF_CATALOGUE[name].trial, "x1", 5, sc)
    rec, truth = realistic_recording(sc, ooc=[o], seed=5)
    assert truth["out_of_catalogue"][0]["name"] == name and not truth["clean"]
    changed = [c for c in clean.channels if not np.array_equal(clean[c], rec[c])]
    assert changed, name


def test_the_foreign_simulator_shares_no_physics_code_with_the_kernel():
    tree = ast.parse(Path(foreign.__file__).read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    forbidden = {"tmopt.physics._closed_loop", "tmopt.physics.dynamics", "tmopt.physics.control",
                 "tmopt.physics.noise", "tmopt.physics.excitation"}
    assert not imported & forbidden, imported & forbidden
    assert "simulate" not in Path(foreign.__file__).read_text().replace("simulation", "")


@pytest.mark.parametrize("convention", ["held", "mean", "end", "symplectic", "explicit"])
def test_the_exact_kinematic_relation_holds_on_the_independent_integrator(convention):
    """A nearly noise-free foreign recording at LPF-like stiffness obeys the exact ZOH
    relation of its accelerometer convention to rounding, and the k = 0 form misses by the
    ~k h^3 v/2 term (held, end) -- RK4 and the derivation agree; one Euler step per
    sample obeys ``held`` with its half-step term, +1 (``symplectic``) or -1
    (``explicit``; docs/mismatch.md 9.26), and every other relation misses each recording
    by far more."""
    euler = {"symplectic": 1.0, "explicit": -1.0}
    sc = replace(short(11, "foreign"), background=QUIET, gaps=(),
                 acc_convention="held" if convention in euler else convention,
                 integrator=convention if convention in euler else "rk4",
                 stiffness=(2e-6, -2e-6, 1.5e-6, -1e-6), force_stamp="applied")  # fmt: skip
    rec, _ = realistic_recording(sc, seed=11, backend="foreign", gaps=False)
    d = data_from_recording(rec)
    d.acc_convention = "held" if convention in euler else convention
    d.stiffness = np.array(sc.stiffness)
    d.halfstep = euler.get(convention, 0.0)
    exact = np.abs(kinematic_target(d)[:2]).max()
    d0 = data_from_recording(rec)
    d0.acc_convention, d0.stiffness = "held", np.zeros(4)
    naive = np.abs(kinematic_target(d0)[:2]).max()
    scale = np.abs(np.diff(rec["x1"], 2)).max()
    assert exact < 1e-9 * scale
    if convention != "mean":
        assert naive > 1e3 * exact
    others = [(c, 0.0) for c in ACC_CONVENTIONS] + [("held", b) for b in euler.values()]
    for other in set(others) - {(d.acc_convention, d.halfstep)}:  # each relation its own
        d.acc_convention, d.halfstep = other
        assert np.abs(kinematic_target(d)[:2]).max() > 1e3 * exact, other


@pytest.mark.parametrize("substeps", [4, 10])
def test_sub_stepped_euler_recordings_obey_the_half_step_relation_to_its_accuracy(substeps):
    """N symplectic Euler sub-steps per sample: the half-step term is 1/N, and its k
    coefficients, the |beta|-weighted mean of the one-step Euler and ``held`` forms, leave
    ~1e-8 of the second difference where either form alone leaves ~1e-6 (at |k| = 2e-6,
    nearly noise-free; docs/mismatch.md 9.26) -- an approximation, far below the readout
    noise (the signal's second difference is ~1e-9 m here, the noise ~2e-11 m)."""
    k = (2e-6, -2e-6, 1.5e-6, -1e-6)
    sc = replace(short(11, "foreign"), background=QUIET, gaps=(), acc_convention="held",
                 integrator="symplectic", substeps=substeps, stiffness=k)  # fmt: skip
    rec, _ = realistic_recording(sc, seed=11, backend="foreign", gaps=False)
    d = data_from_recording(rec)
    d.stiffness, scale = np.array(k), np.abs(np.diff(rec["x1"], 2)).max()

    def misfit(halfstep, k_form=None):
        d.halfstep = halfstep
        if k_form is None:
            return np.abs(kinematic_target(d)[:2]).max() / scale
        n, h = d.kin_index, d.dt
        # k_form 1: one Euler step's (1, 2, h^2/2); 0: held's (C, 1 + C, (C - 1)/k)
        cp, cm, g = (np.asarray(v)[:2, None] for v in kinematic_coefficients(
            np.array(k), h, "held", k_form))  # fmt: skip
        acc = (1 + halfstep) * d.acc[:2, n] + (1 - halfstep) * d.acc[:2, n - 1]
        return np.abs(d.x[:2, n + 1] - cm * d.x[:2, n] + cp * d.x[:2, n - 1]
                      - g * acc).max() / scale  # fmt: skip

    got = misfit(1.0 / substeps)
    assert got < 1e-7
    assert misfit(1.0 / substeps, k_form=1.0) > 30 * got  # one Euler step's k form
    assert misfit(1.0 / substeps, k_form=0.0) > 30 * got  # held's k form
    assert misfit(0.0) > 1e3 * got and misfit(1.0) > 1e3 * got


def test_kinematic_coefficients_reduce_to_the_k0_relation_and_match_closed_forms():
    h = 0.5
    for conv in ACC_CONVENTIONS:
        cp, cm, g = kinematic_coefficients(np.zeros(4), h, conv)
        assert np.allclose(cp, 1) and np.allclose(cm, 2) and np.allclose(g, h * h / 2)
    k = np.array([2e-6, -2e-6, 1e-3, -1e-3])
    c = np.where(k > 0, np.cosh(np.sqrt(np.abs(k)) * h), np.cos(np.sqrt(np.abs(k)) * h))
    cp, cm, g = kinematic_coefficients(k, h, "held")
    assert np.allclose(cp, c, rtol=1e-14) and np.allclose(g, (c - 1) / k, rtol=1e-10)
    sq = np.sqrt(np.abs(k))
    s_over = np.where(k > 0, np.sinh(sq * h) * sq, -np.sin(sq * h) * sq)  # sqrt(k) sinh(sqrt(k) h)
    _, _, gm = kinematic_coefficients(k, h, "mean")
    assert np.allclose(gm, h * (c - 1) / s_over, rtol=1e-10)
    cp, cm, g = kinematic_coefficients(k, h, "end")  # held's relation divided by C
    assert np.allclose(cp, 1 / c, rtol=1e-14) and np.allclose(cm, 1 + 1 / c, rtol=1e-14)
    assert np.allclose(g, (c - 1) / (k * c), rtol=1e-10)
    for beta in (1.0, -1.0):  # one Euler step: exact at any k, h^2/2 (a_n + a_n +- ...)
        cp, cm, g = kinematic_coefficients(k, h, "held", beta)
        assert np.all(cp == 1) and np.all(cm == 2) and np.allclose(g, h * h / 2, rtol=1e-15)
    cp, cm, g = kinematic_coefficients(k, h, "held", 0.25)  # sub-steps: a weighted mean
    ch, mh, gh = kinematic_coefficients(k, h, "held")
    assert np.allclose(cp, 0.75 * ch + 0.25) and np.allclose(g, 0.75 * gh + 0.25 * h * h / 2)
    for conv in ("mean", "end"):  # with a half-step term the relation is held's blend,
        # whichever convention places Eq. 10's stiffness term (an integrating readout, 9.27)
        got = kinematic_coefficients(k, h, conv, -1.0)
        assert all(np.array_equal(a, b) for a, b in zip(got, kinematic_coefficients(k, h, "held",
                                                                               -1.0)))


def test_injected_catalogue_effects_reach_both_simulators():
    sc = replace(short(13, "foreign"), gaps=())
    inj = Injection("actuation_gain", 0.01, "x1")
    for backend in ("kernel", "foreign"):
        clean, _ = realistic_recording(sc, seed=13, backend=backend)
        rec, _ = realistic_recording(sc, [inj], seed=13, backend=backend)
        # the applied (not the commanded) force changes: acc moves, x1's force channel
        # differs only through the loop's reaction
        assert not np.array_equal(clean["acc_x1"], rec["acc_x1"])
        assert np.array_equal(clean["x2"][:10], rec["x2"][:10])


def test_bad_backend_and_seed_are_refused_in_one_line():
    with pytest.raises(ValueError, match="backend must be one of"):
        draw_scenario(0, "other")
    with pytest.raises(ValueError, match="seed must be an integer"):
        realistic_recording(short(0), seed=-1)
    assert AXES == ("x1", "x2", "y1", "y2")


def test_a_tiny_actuation_delay_is_a_tiny_change_on_the_foreign_held_accelerometer():
    """The held accelerometer reports the force over the step (its interval average where
    a delayed command switches inside it), as the kernel does: a delay of 1e-6 s must not
    shift the accelerometer by a whole sample (it did: the scaler then drove delays to
    ~1e-14 s at SNR ~1e4)."""
    sc = short(30036, "foreign", acc_convention="held", gaps=(), glitches=())
    base, _ = realistic_recording(sc, (), (), 30036, "foreign")
    late, _ = realistic_recording(sc, [Injection("actuation_delay", 1e-6, "x1")], (), 30036,
                                  "foreign")  # fmt: skip
    step = np.std(np.diff(base["force_x1"]))
    assert np.max(np.abs(late["acc_x1"] - base["acc_x1"])) < 1e-3 * step


def _applied_stamp(rec: Recording) -> Recording:
    """A 'previous'-stamped recording re-stamped by hand: force[n + 1] beside sample n, the
    last sample dropped (the truth's convention, not the tool's detection)."""
    ch = {k: (v[:-1] if not k.startswith("force_") else v[1:]) for k, v in rec.channels.items()}
    return Recording(ch, dict(rec.attrs))


def test_the_snr_scaler_pairs_the_forces_as_the_tool_does():
    """Scaler version 2 (docs/mismatch.md 10): a foreign recording stamped 'previous' is
    measured with its force channels aligned by the tool's criterion, so an effect scaled
    to SNR 40 has SNR 40 in families re-stamped by hand from the truth; version 1 measured
    it against the misaligned force's step-to-step change and scaled it ~50x too loud."""
    seed = 17
    sc = replace(short(seed, "foreign"), gaps=(), force_stamp="previous")
    v1, v2 = (_clean_cache(sc, seed, "foreign", v) for v in (1, 2))
    assert v2["force_lag"] == 1 and v1["force_lag"] == 0
    assert _clean_cache(replace(sc, force_stamp="applied"), seed, "foreign")["force_lag"] == 0
    assert _clean_cache(short(seed), seed, "kernel")["force_lag"] == 0
    step = make_ooc("force_step", 1e-12, "x1", seed, sc)
    step2, rho2 = scale_to_snr(sc, step, 40.0, seed, "foreign", v2)
    step1, _ = scale_to_snr(sc, step, 40.0, seed, "foreign", v1)
    assert abs(rho2 / 40 - 1) < 0.15
    assert abs(step1.magnitude) > 10 * abs(step2.magnitude)

    def eq(seed_, ooc=()):
        rec = realistic_recording(sc, (), ooc, seed_, "foreign", gaps=False)[0]
        return residual_families(_applied_stamp(rec))["eq"]

    a, b = eq(seed), eq(seed + 7919)
    psd = _psd_on_grid((a - b) / math.sqrt(2), sc.sample_rate)
    by_hand = matched_snr(whitened_power(eq(seed, [step2]) - a, psd, sc.sample_rate))
    assert by_hand == pytest.approx(rho2, rel=0.05)
    with pytest.raises(ValueError, match="version must be one of"):
        _clean_cache(sc, seed, "foreign", 3)
