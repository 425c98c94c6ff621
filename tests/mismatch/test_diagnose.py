"""End-to-end diagnosis on simulated recordings: silence on clean data, the right effect
(and channel) when one is synthesised, two effects in turn, identifiability statements."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from tmopt.mismatch.diagnose import Settings, _identifiable, diagnose, fit_state
from tmopt.mismatch.effects import Candidate
from tmopt.mismatch.fit import Column, data_from_result, null_basis
from tmopt.physics import MultiSine, SimulationConfig, simulate

from .test_effects import add_force

REF1 = MultiSine([[5e-5, 2e-5]], [[2 * math.pi / 300, 2 * math.pi / 70]])
REF2 = MultiSine(3e-5, 2 * math.pi / 500)


@pytest.fixture(scope="module")
def clean():
    return data_from_result(simulate(REF1, REF2, SimulationConfig(duration=600.0), seed=21))


@pytest.fixture(scope="module")
def clean_diagnosis(clean):
    return diagnose(clean)


def test_clean_recording_gives_no_mismatch(clean_diagnosis):
    dg = clean_diagnosis
    assert not dg.mismatch_detected and not dg.selected and not dg.unexplained
    assert min(e.p_holm for e in dg.steps[0]) > dg.settings.alpha


def test_clean_recording_lists_what_it_cannot_see(clean_diagnosis):
    keys = {(r["name"], r["channel"], r["reason"]) for r in clean_diagnosis.not_identifiable}
    # y is held at rest: the x<-y cross stiffness has no excitation
    assert ("stiffness_cross_coupling", "x1<-y1", "not excited") in keys
    assert all(r["needs"] for r in clean_diagnosis.not_identifiable)


def test_a_gain_error_is_found_on_its_axis_and_the_stiffness_improves(clean):
    d = copy.deepcopy(clean)
    add_force(d, 0, 2e-4 * d.force[0])  # applied force (1 + 2e-4) x commanded on x1
    dg = diagnose(d)
    (ev, _), *_ = dg.selected
    assert ev.candidate.key == "actuation_gain[x1]"
    k_before = dg.before.eq_fit.value("k1xx")
    k_after = dg.after.eq_fit.value("k1xx")
    assert abs(k_after - 1e-7) < abs(k_before - 1e-7) / 5


def test_two_effects_are_found_in_turn(clean):
    d = copy.deepcopy(clean)
    add_force(d, 0, 3e-4 * d.force[0])
    add_force(d, 1, 5e-14 * d.centred_time)
    dg = diagnose(d)
    keys = {ev.candidate.key for ev, _ in dg.selected}
    assert {"actuation_gain[x1]", "bias_drift[x2]"} <= keys
    assert not dg.unexplained


def test_unexplained_mismatch_is_located(clean):
    d = copy.deepcopy(clean)
    # a square-wave force at 0.8 Hz on y2 only between 200 and 260 s: no catalogue term
    t = d.time
    e = np.where((t > 200) & (t < 260), 2e-11 * np.sign(np.sin(2 * math.pi * 0.8 * t)), 0.0)
    add_force(d, 3, e)
    dg = diagnose(d, Settings(max_effects=2))
    assert dg.mismatch_detected and dg.unexplained
    loc = dg.locations_after  # what the final model leaves: the burst and its 0.8 Hz line
    assert any(t0 <= 260 and t1 >= 200 for t0, t1 in loc.time_s)
    assert any(lo <= 0.8 <= hi for lo, hi in loc.frequency_hz)


def test_a_candidate_inside_the_nominal_span_is_called_aliased(clean):
    basis = null_basis(clean.geometry)
    st = fit_state(clean, basis, [], [], False, Settings())
    cols = st.eq_cols[: st.n_nominal_eq]
    x0 = np.column_stack([st.eq_noise.whiten(c.values).ravel() for c in cols])
    twin = Column("twin_of_k1xx", 1e-9 * cols[0].values)  # a tiny copy of k1xx's regressor
    cand = Candidate("actuation_gain", "x1", "equation", ["g"], ["1"], [twin], 0.05)
    rec = _identifiable(cand, cols, x0, st.eq_noise.whiten, 30.0)
    assert rec["reason"] == "aliased" and rec["aliased_with"] == "k1xx"


def test_holm_and_ljung_box_match_their_definitions():
    from tmopt.mismatch.diagnose import holm, ljung_box

    # Holm: sorted p * (m - i), running maximum, capped at 1
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03]), [0.03, 0.06, 0.06])
    assert holm([0.5, 0.9]).tolist() == [1.0, 1.0]
    x = np.random.default_rng(5).standard_normal(400)
    n, lags = x.size, 10
    xc = x - x.mean()
    r = np.array([xc[k:] @ xc[: n - k] for k in range(1, lags + 1)]) / (xc @ xc)
    q = n * (n + 2) * np.sum(r**2 / (n - np.arange(1, lags + 1)))
    from scipy import stats

    assert abs(ljung_box(x, lags) - stats.chi2.sf(q, lags)) < 1e-12


def _ev(effect: str, channel: str, glr: float, n_obs: int = 10_000):
    from types import SimpleNamespace

    from tmopt.mismatch.diagnose import Evaluation

    cand = SimpleNamespace(effect=effect, channel=channel, key=f"{effect}[{channel}]",
                           n_searched=0)  # fmt: skip
    return Evaluation(cand, glr=glr, dof=1, n_obs=n_obs, p_value=0.0)


def test_weak_and_remainder_names_are_flagged_by_their_definitions():
    """:func:`weak_names`: delta BIC = glr - ln n below AMBIGUOUS_DBIC is "weak"; a GLR
    below MODEL_PRECISION^2 of a stronger selected *searched* effect's on a shared axis
    ("all axes" shares every axis) is "remainder"; an effect on other axes, above the
    precision, or beside a linear effect keeps its name (r4's case: a quantisation at
    GLR 47321 with an actuation delay at 33 on x2 -- ratio sqrt(33/47321) = 0.026)."""
    from tmopt.mismatch import calibration as cal
    from tmopt.mismatch.diagnose import weak_names

    ln_n = math.log(10_000)
    q = _ev("actuation_quantisation", "all axes", 47321.0)
    delay = _ev("actuation_delay", "x2", 33.1)
    weak = _ev("sensing_cross_talk", "acc:x2<-y1", ln_n + cal.AMBIGUOUS_DBIC - 1.0)
    drift = _ev("bias_drift", "x1", 40000.0)
    gain = _ev("actuation_gain", "x1", (2 * cal.MODEL_PRECISION) ** 2 * 40000.0)
    glitch = _ev("glitch", "x2", 20.0 + ln_n)  # x2 only: drift's x1 is not shared
    out = weak_names([(e, []) for e in (q, delay, weak)])
    assert {w["key"]: (w["kind"], w["of"]) for w in out} == {
        "actuation_delay[x2]": ("remainder", "actuation_quantisation[all axes]"),
        "sensing_cross_talk[acc:x2<-y1]": ("weak", None)}  # fmt: skip
    assert weak_names([(drift, []), (glitch, []), (gain, [])]) == []
    # below eps of a linear effect (a drift): no remainder -- it is fitted exactly in its
    # span (the 0.2 s delay with a drift at 1/20 of its signal); of a searched one
    # (a quantisation): a remainder
    tiny = _ev("actuation_gain", "x1", (cal.MODEL_PRECISION / 2) ** 2 * 40000.0)
    assert weak_names([(drift, []), (tiny, [])]) == []
    q2 = _ev("actuation_quantisation", "all axes", 40000.0)
    assert [w["kind"] for w in weak_names([(q2, []), (tiny, [])])] == ["remainder"]


def test_pieces_of_one_glitch_are_one_event():
    """:func:`events` with :meth:`Glitch.same_event`: glitch pieces on one axis with
    onsets within EVENT_WIDTHS widths group together; another axis, a later glitch, or
    another effect stand alone."""
    from tmopt.mismatch.diagnose import events

    def glitch(ch: str, t0: float, beta: float):
        ev = _ev("glitch", ch, 100.0)
        ev.candidate.fixed = {"t0_s": t0, "decay_s": beta}
        return ev

    sel = [glitch("x1", 591.7, 5.0), _ev("bias_drift", "x1", 50.0),
           glitch("x1", 598.7, 6.8), glitch("x2", 592.0, 5.0), glitch("x1", 900.0, 5.0),
           glitch("x1", 592.4, 0.9)]  # fmt: skip
    assert events([(e, []) for e in sel]) == [[0, 2, 5], [1], [3], [4]]
