"""A drift's shape check searches a step and a relaxation on its axis (issue 26, stop 41;
docs/mismatch.md 9.17): :meth:`tmopt.mismatch.effects.base.Effect.shape_search`, judged in
:func:`tmopt.mismatch.diagnose.shape_misfits` with Legendre P2 + P3 (Bonferroni over the
checks), a searched shape counting only where, fitted in the drift's place, it explains
more than the drift (:func:`tmopt.mismatch.diagnose._replaced_by`).

The recordings are the shape calibration's (``experiments/mismatch_shape_calibration.py``,
calibration seeds, never a benchmark's): the rule was designed on them, so these tests hold
the design cases, and the rates are measured on fresh seeds (35000 on) and a never-seen
benchmark draw."""

from __future__ import annotations

import functools
import json
import sys
from pathlib import Path

import pytest

from tmopt.mismatch import diagnose as dgn
from tmopt.mismatch.diagnose import Settings
from tmopt.mismatch.report import build_report

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@functools.cache
def _diagnosed_once(set_: str, backend: str, seed: int, true_position: bool = True):
    sys.path.insert(0, str(EXPERIMENTS))
    try:
        from mismatch_realistic import diagnosed_case
        from mismatch_shape_calibration import jobs
    finally:
        sys.path.remove(str(EXPERIMENTS))
    base = 33000 if seed < 35000 else 35000
    [job] = [j for j in jobs(20, "bias_drift", base)
             if (j["set"], j["backend"], j["seed"]) == (set_, backend, seed)]  # fmt: skip
    return diagnosed_case(job, Settings(true_position=true_position))


def _diagnosed(set_: str, backend: str, seed: int, true_position: bool = True):
    """The calibration job's recording (its set and seed) diagnosed with the defaults
    (once per module: the parametrised test reads the same diagnosis).  ``true_position``
    False: the gate's design cases as they were found (before docs/mismatch.md 9.19; on the
    true position kernel 33013's kink is no longer significant, p 0.0035, and kernel
    33012's drift is flagged -- 9.19 and section 10)."""
    dg, _, error = _diagnosed_once(set_, backend, seed, true_position)
    assert error is None, error
    return dg


def _drift(dg):
    [ev] = [ev for ev, _ in dg.selected if ev.candidate.effect == "bias_drift"]
    return ev.candidate.key


def test_a_relaxation_that_p2_p3_let_pass_as_a_ramp_is_not_named_a_drift():
    """Kernel 35519: a thermal relaxation (SNR 40) selected as ``bias_drift``; P2 + P3 leave
    it at p 0.19, the searched relaxation beside the drift is significant after its trials
    and explains more in the drift's place (GLR 32 against 19): a shape misfit, the name
    ambiguous, the channel unexplained.  Without the search the drift was named."""
    dg = _diagnosed("power", "kernel", 35519)
    key = _drift(dg)
    fixed_only = dgn.shape_misfits(dg.data, dg.basis, dg.after, dg.selected, search=False)
    assert not fixed_only, fixed_only
    [m] = [m for m in dg.misfits if m["key"] == key]
    assert m["shape"].startswith(("a step", "a relaxation")) and m["p_value"] < 0.01, m
    searched = m["checks"][1:]
    assert any(c["p_value"] < 0.01 for c in searched), m["checks"]
    assert any(c["replaced"] for c in searched), m["checks"]
    assert all(c["glr_in_place"] > c["glr_effect"] + c["margin"]
               for c in searched if c["replaced"]), m["checks"]  # fmt: skip
    rep = build_report(dg)
    assert not any(e["name"] == "bias_drift" for e in rep["effects"]), rep["conclusion"]
    [amb] = [a for a in rep["ambiguous"] if a["name"] == "bias_drift"]
    [rival] = [r for r in amb["rivals"]
               if r["name"].startswith(f"shape misfit (its residual needs {m['shape']}")]
    assert rival["checks"] == m["checks"]  # every check reaches the report
    assert json.loads(json.dumps(rep))["ambiguous"]  # plain JSON, as write_report needs


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_kink_of_the_background_beside_a_true_drift_does_not_take_its_name(monkeypatch):
    """Kernel 33013: a true linear drift (SNR 60) on the 1/f^2 background; a step beside
    it is significant after its trials (p 0.0026, x3 checks 0.008) -- a random walk's kink --
    but in the drift's place no step or relaxation explains as much as the ramp (GLR 34
    against 36), so it does not count and the drift keeps its name.  Counted regardless
    (the gate off), the drift would be a shape misfit."""
    dg = _diagnosed("null", "kernel", 33013, true_position=False)
    key = _drift(dg)
    assert not [m for m in dg.misfits if m["key"] == key], dg.misfits
    [c] = dgn.shape_misfits(dg.data, dg.basis, dg.after, dg.selected, 1.0)
    assert not c["checks"][1]["replaced"] and c["checks"][1]["p_searched"] < 0.01 / 3
    monkeypatch.setattr(dgn, "_replaced_by", lambda *a, **k: {
        f: {"replaced": True, "glr_effect": 0.0, "glr_in_place": 1.0, "margin": 0.0}
        for f in ("step", "relaxation")})  # fmt: skip
    ungated = dgn.shape_misfits(dg.data, dg.basis, dg.after, dg.selected)
    assert [m["key"] for m in ungated] == [key], ungated


@pytest.mark.slow  # a 8 s diagnosis study: CI's 15 min (`make test-slow`)
def test_a_relaxation_that_only_ties_with_a_true_ramp_does_not_replace_it():
    """Kernel 33012: a true linear drift (SNR 20) beside which a step is significant after
    its trials (p 7e-5); in the drift's place the best relaxation -- a long tau is a ramp --
    ties with it (GLR 19.3 against 19.3).  Charged its two extra parameters (Akaike's 2
    each) it does not replace the drift, nor does the step (19.3 < 19.3 + 2), and the
    drift keeps its name.  (Found when the design set was re-run with the first gate,
    which compared the GLRs bare and flagged this drift.)"""
    dg = _diagnosed("null", "kernel", 33012, true_position=False)
    key = _drift(dg)
    assert not [m for m in dg.misfits if m["key"] == key], dg.misfits
    [c] = dgn.shape_misfits(dg.data, dg.basis, dg.after, dg.selected, 1.0)
    step, relax = c["checks"][1:]
    assert step["p_searched"] < 1e-3 and (step["margin"], relax["margin"]) == (2.0, 4.0)
    assert abs(relax["glr_in_place"] - relax["glr_effect"]) < relax["margin"], relax
    assert not step["replaced"] and not relax["replaced"]


@pytest.mark.parametrize("search", [pytest.param(True, marks=pytest.mark.slow),  # 12 s
                                    pytest.param(False, marks=pytest.mark.slow)])  # 36 s
def test_the_searched_checks_are_listed_only_with_the_switch(search):
    """``search=False`` is the check before stop 41: P2 + P3 alone, one entry in
    ``checks``; with it, the step and the relaxation follow, each with its in-place
    comparison."""
    dg = _diagnosed("null", "foreign", 35000)
    [c] = dgn.shape_misfits(dg.data, dg.basis, dg.after, dg.selected, 1.0, search=search)
    shapes = [x["shape"].split(" ")[1] for x in c["checks"]]
    assert shapes == (["curvature", "step", "relaxation"] if search else ["curvature"])
    assert all("glr_in_place" in x for x in c["checks"][1:])
