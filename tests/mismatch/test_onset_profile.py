"""A generic force step or relaxation read by its profile likelihood ratio (issue 26;
docs/mismatch.md 9.30; :func:`tmopt.mismatch.diagnose._equation_profile`).

A lasting force step puts its power in the lowest bins of the equation residual, where
the acceleration noise's 1/f^2 spectrum rests on a few periodogram bins: the null's noise
model is estimated from a residual that holds the step and takes it in.  The profile
ratio fits the step's column *and* estimates the noise model again under it, each fit
scored by Whittle's likelihood under its own model (as ``kin_profile``, 9.29).
Development seeds (< 20000).  Off by default (``Settings.onset_profile``): on two
never-seen draws it reported one force step more, and on the second it moved no row
(docs 9.30, 9.31).
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from tmopt.mismatch import generic
from tmopt.mismatch.diagnose import (
    ONSET_FEATURES,
    Evaluation,
    Settings,
    _best,
    _equation_alternatives,
    _fit_eq,
    _generic_feature,
    _given,
    _holm_adjusted,
    _rivals,
    _tests,
    diagnose,
    fit_state,
    prepare,
    residual_groups,
)
from tmopt.mismatch.effects import Candidate, Context, Injection
from tmopt.mismatch.fit import data_from_recording, equation_target
from tmopt.mismatch.realistic import draw_scenario, make_ooc, realistic_recording

from .test_kin_profile import _whittle_by_hand

ON = Settings(onset_profile=True)
SEED = 16001  # kernel; a 1500 s record, x1 excited
STEP = 2e-12  # m s^-2: GLR 29.5 under the null's spectrum (below the level), profile 60.4


def _recording(seed: int, backend: str, step: float = 0.0):
    sc = draw_scenario(seed, backend)
    sc = replace(sc, duration=min(sc.duration, 1500.0))
    ooc = [make_ooc("force_step", step, "x1", seed, sc)] if step else []
    return realistic_recording(sc, [], ooc, seed, backend)[0], ooc


@pytest.fixture(scope="module")
def stepped():
    rec, [ooc] = _recording(SEED, "kernel", STEP)
    return rec, ooc, diagnose(data_from_recording(rec), ON)


def _onset_feature(cand: Candidate) -> bool:
    return _generic_feature(cand) in ONSET_FEATURES


def _onset_candidates(d, basis, st):
    ctx = Context(d, basis, st.eq_fit.residual, st.eq_noise)
    return [c for c in generic.candidates(ctx) if _onset_feature(c)]


def test_a_force_step_the_null_spectrum_takes_in_is_reported_unexplained(stepped):
    """Read by its profile ratio, the step is selected as an unexplained onset on x1 at
    its time; the default (off) says nothing on the same record."""
    rec, ooc, dg = stepped
    [(ev, _)] = dg.selected
    c = ev.candidate
    assert c.effect == generic.GENERIC and c.channel == "x1", c.key
    assert c.fixed["feature"] in ("step", "relaxation")
    assert abs(c.fixed["t0_s"] - ooc.params["t_step"]) < 30.0, (c.fixed, ooc.params)
    assert not diagnose(data_from_recording(rec)).selected


def test_the_statistic_is_the_profile_ratio_computed_a_second_way(stepped):
    """The statistic equals ``2 (ll1 - ll0) / inflation`` with both likelihoods computed by
    hand (numpy FFT, scipy B-splines), and is well above the GLR under the null's model."""
    dg = stepped[2]
    d, basis = dg.data, dg.basis
    st = fit_state(d, basis, [], [], False, ON)
    cand = max(_onset_candidates(d, basis, st), key=lambda c: c.fixed["feature"] == "step")
    read = _equation_alternatives(d, basis, st, ON)["equation_profile"]
    got = read(cand.columns, 1e9)
    fit1, noise1 = _fit_eq(equation_target(d, basis), st.eq_cols + cand.columns, st.red,
                           d.layout, d.fs, st.eq_noise.kind)  # fmt: skip
    ll0 = _whittle_by_hand(st.eq_fit.residual, st.eq_noise)
    ll1 = _whittle_by_hand(fit1.residual, noise1)
    want = 2 * (ll1 - ll0) / st.eq_noise.taper_inflation()
    assert got == pytest.approx(want, rel=1e-6), (got, want)
    lam = residual_groups(d, st)["equation"].glr(cand.columns)
    assert lam < 36 < 50 < got, (lam, got)


def test_backward_elimination_reads_it_by_its_profile_too(stepped):
    """``_given`` rebuilds the model without the step, where the null's spectrum takes it
    in again: read by its profile ratio it stays needed; off, it would go."""
    dg = stepped[2]
    chosen = [ev for ev, _ in dg.selected]
    n_tests = len(dg.steps[0])
    p, dbic = _given(dg.data, dg.basis, chosen, 0, dg.settings, n_tests)
    assert p < dg.settings.alpha and dbic > 0, (p, dbic)
    p_off, _ = _given(dg.data, dg.basis, chosen, 0, Settings(), n_tests)
    assert p_off > dg.settings.alpha, p_off


@pytest.mark.parametrize("backend", ["kernel", "foreign"])
def test_on_a_clean_recording_no_onset_reaches_significance(backend):
    """Under "no effect" no onset feature read by its profile ratio reaches the family's
    level after its search and the Holm ladder; every GLR, and every other candidate's
    p-value, is the one the default computes."""
    d, basis = prepare(data_from_recording(_recording(SEED, backend)[0]))
    st = fit_state(d, basis, [], [], False, Settings())
    on = _tests(d, basis, st, ON, set())[0]
    off = _tests(d, basis, st, Settings(), set())[0]
    onset = [e for e in on if _onset_feature(e.candidate)]
    assert onset
    assert all(e.p_value * len(on) > ON.alpha for e in onset), [
        (e.candidate.key, e.glr, e.p_value) for e in onset]  # fmt: skip
    assert [e.candidate.key for e in on] == [e.candidate.key for e in off]
    assert all(a.glr == b.glr for a, b in zip(on, off))
    assert all(a.p_value == b.p_value for a, b in zip(on, off) if a not in onset)


def test_only_the_significance_of_an_onset_moves(stepped):
    """On the stepped record the step's GLR -- what BIC gains and the ambiguity band
    compare -- is the default's; its p-value is the profile ratio's, far smaller."""
    d, basis = stepped[2].data, stepped[2].basis
    st = fit_state(d, basis, [], [], False, Settings())
    on = _tests(d, basis, st, ON, set())[0]
    off = _tests(d, basis, st, Settings(), set())[0]
    moved = [(a, b) for a, b in zip(on, off) if a.p_value != b.p_value]
    assert moved and all(_onset_feature(a.candidate) for a, _ in moved)
    assert all(a.glr == b.glr for a, b in zip(on, off))
    m = len(on)  # Holm's first step: off, no onset reaches it; on, the step does
    assert min(a.p_value for a, _ in moved) * m < ON.alpha < min(b.p_value for _, b in moved) * m


@pytest.mark.parametrize("seed,backend", [(16001, "foreign"), (16002, "kernel")])
def test_a_bias_drift_is_still_named_a_drift(seed, backend):
    """A ramp of the force is taken into the null's spectrum as a step is; had the onset's
    profile ratio entered the ranking, a step would out-rank the drift read by its GLR
    (both records: the drift named off, the step 'unexplained' on x1 with the ratio in
    the ranking; docs 9.30)."""
    sc = draw_scenario(seed, backend)
    sc = replace(sc, duration=min(sc.duration, 1500.0))
    rec = realistic_recording(sc, [Injection("bias_drift", 1e-15, "x1")], [], seed, backend)[0]
    dg = diagnose(data_from_recording(rec), ON)
    assert [ev.candidate.key for ev, _ in dg.selected] == ["bias_drift[x1]"]


def test_a_bad_switch_is_refused_naming_it():
    with pytest.raises(ValueError, match="onset_profile must be True or False"):
        Settings(onset_profile=1)


def _ev(effect: str, glr: float, p_holm: float, p_holm_glr: float | None = None):
    """An evaluation with the numbers :func:`_best` reads (one column, no search)."""
    fixed = {"feature": "step"} if effect == generic.GENERIC else {}
    cand = Candidate(effect, "x2", "equation", ["a"], ["m s^-2"], fixed=fixed)
    ev = Evaluation(cand, glr, 1, 20000, p_holm, p_holm)
    if p_holm_glr is not None:
        ev.p_glr, ev.p_holm_glr = p_holm, p_holm_glr
    return ev


def test_an_onset_significant_only_by_its_ratio_does_not_displace_a_named_effect():
    """Kernel 290145 and 290147 (docs 9.30): an onset at a glitch's place, ahead of it in
    the GLR ranking and insignificant there, made significant by its profile ratio, took
    the glitch's place.  It ranks after every candidate significant by its GLR, and is no
    near rival of one; where nothing else is significant it is taken (the force step of
    kernel 280112); an onset significant by its GLR ranks as before."""
    alpha = ON.alpha
    glitch = _ev("glitch", 60.0, 1e-6)
    rescued = _ev(generic.GENERIC, 70.0, 1e-3, 0.3)
    plain = _ev(generic.GENERIC, 70.0, 1e-3, 1e-3)
    assert rescued.by_profile_only(alpha) and not plain.by_profile_only(alpha)
    assert _best([glitch, rescued], alpha) is glitch
    assert _rivals([glitch, rescued], glitch, alpha) == [glitch]
    assert _best([rescued], alpha) is rescued
    assert _best([glitch, plain], alpha) is plain
    assert _rivals([glitch, plain], plain, alpha) == [glitch, plain]


def test_holm_adjusts_the_glr_p_values_beside_the_ratios():
    """``p_holm_glr``: Holm's ladder over the step's p-values with each onset's GLR
    p-value in place of its ratio's; an evaluation that read its GLR keeps its own."""
    evs = [_ev("glitch", 60.0, 0.001), _ev(generic.GENERIC, 70.0, 0.002, 0.002)]
    evs[1].p_glr = 0.02  # its GLR alone: 0.02 before the ladder
    _holm_adjusted(evs)
    assert evs[0].p_holm == pytest.approx(0.002) and evs[1].p_holm == pytest.approx(0.002)
    assert evs[1].p_holm_glr == pytest.approx(0.02) and evs[0].p_holm_glr == evs[0].p_holm
    assert evs[1].by_profile_only(0.01) and not evs[0].by_profile_only(0.01)
