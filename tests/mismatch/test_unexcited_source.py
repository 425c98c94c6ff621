"""A readout term from an axis that carries no excitation is tested by least squares
(docs/mismatch.md 9.12, :data:`tmopt.mismatch.effects.base.UNEXCITED_SOURCE_OLS`).

A kinematic candidate ``disp:a<-b`` regresses readout a's kinematic residual on
``h^2 acc_b``, instrumented by acc_b's part at b's excitation tones.  Without tones on b
that part is zero, and a displacement cross-talk from a y axis that moves with its own
noise alone -- every y axis of the kernel simulator -- was untestable, though it can be
far above the noise (80000 set: 4 of 5 cross-talk misses).  For b != a, acc_b carries b's
noise only, so the plain regressor is exogenous in readout a; its null on clean recordings
is chi^2(1) (experiments/mismatch_open_source_null.py).  Development seeds (< 20000) only.
"""

from __future__ import annotations

import numpy as np
import pytest

import tmopt.mismatch.effects.base as base
from tmopt.mismatch.diagnose import Settings, diagnose, fit_state, prepare
from tmopt.mismatch.effects import Injection
from tmopt.mismatch.effects.base import Context
from tmopt.mismatch.effects.readout_scale import ReadoutScale
from tmopt.mismatch.effects.sensing_cross_talk import SensingCrossTalk
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.realistic import draw_scenario, realistic_recording
from tmopt.mismatch.report import build_report

SEED = 17051
CROSS_TALK = 1.0e-3  # y1 seen by the x1 readout; plausible up to 1e-2


def _recording(effects):
    sc = draw_scenario(SEED, "kernel", duration=1200.0, sample_rate=2.5, gaps=())
    rec, _ = realistic_recording(sc, effects, [], SEED, "kernel")
    return data_from_recording(rec)


def _cross_talk():
    return _recording([Injection("sensing_cross_talk", CROSS_TALK, "x1",
                                 options={"source": "y1", "sensor": "disp"})])  # fmt: skip


@pytest.fixture(scope="module")
def clean_context():
    data, basis = prepare(_recording([]))
    state = fit_state(data, basis, [], [], False, Settings())
    return Context(data, basis, state.eq_fit.residual, state.eq_noise)


def test_only_a_term_of_the_own_axis_keeps_its_instrument(clean_context, monkeypatch):
    """A term from another axis, unexcited (9.12) or excited (stop 42, 9.18 (c):
    ``EXCITED_SOURCE_OLS``), is its own instrument; the own axis keeps its tone part."""
    d = clean_context.data
    assert d.tones(0) and d.tones(1) and not d.tones(2) and not d.tones(3)  # kernel: no y
    cols = {c.key: c.columns[0] for c in SensingCrossTalk().candidates(clean_context)}
    assert cols["sensing_cross_talk[disp:x1<-y1]"].instrument is None
    assert cols["sensing_cross_talk[disp:y1<-x1]"].instrument is None  # x1 is excited
    monkeypatch.setattr(base, "EXCITED_SOURCE_OLS", False)  # the rule before stop 42
    cols = {c.key: c.columns[0] for c in SensingCrossTalk().candidates(clean_context)}
    excited = cols["sensing_cross_talk[disp:y1<-x1]"].instrument
    assert excited is not None and np.any(excited)
    assert cols["sensing_cross_talk[disp:x1<-y1]"].instrument is None
    for c in ReadoutScale().candidates(clean_context):  # own axis: the loop's noise, IV kept
        for col in c.columns + ([c.twin] if c.twin is not None else []):
            if col.row is not None and col.tones == ():
                assert col.instrument is not None


def test_a_cross_talk_from_an_unexcited_y_axis_is_named():
    rep = build_report(diagnose(_cross_talk()))
    assert [(e["name"], e["channel"]) for e in rep["effects"]] == [
        ("sensing_cross_talk", "disp:x1<-y1")]
    e = rep["effects"][0]
    c, sigma = e["parameters"]["c"], e["uncertainties"]["c"]
    assert abs(c - CROSS_TALK) < 5 * sigma < 0.5 * CROSS_TALK  # the value, within 5 sigma


def test_without_the_rule_the_same_cross_talk_is_missed(monkeypatch):
    """The failure the rule fixes (it holds with the rule off: the term was untestable)."""
    monkeypatch.setattr(base, "UNEXCITED_SOURCE_OLS", False)
    rep = build_report(diagnose(_cross_talk()))
    assert not any(e["name"] == "sensing_cross_talk" for e in rep["effects"])


def test_an_accelerometer_cross_talk_from_an_unexcited_axis_is_named_alone():
    """Its kinematic twin (``-c h^2 acc_b`` in readout a) is tested by least squares and,
    once the name is chosen, joins the kinematic fit -- else the disp variant of the same
    pair would take the twin's term as a second name."""
    data = _recording([Injection("sensing_cross_talk", 3.0e-3, "x1",
                                 options={"source": "y1", "sensor": "acc"})])  # fmt: skip
    rep = build_report(diagnose(data))
    assert [(e["name"], e["channel"]) for e in rep["effects"]] == [
        ("sensing_cross_talk", "acc:x1<-y1")]
    assert not rep["unexplained"], rep["unexplained_at"]
