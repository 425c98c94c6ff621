"""Ambiguous names as design targets (docs/design.md, "Ambiguous names").

A cubic stiffness under the paper's one-tone excitation is reported ambiguous with the
unnamed ``x|x|`` force (after the linear part they differ by the 5th and higher
harmonics); the design separates the pair -- the cubic's standard error with ``x|x|``
profiled, at the noise the diagnosis selects with, makes the expected delta-BIC gap
exceed the ambiguity band -- and a recording made with it (same effect, new noise) gets
the cubic named, within its uncertainty of the truth.  Development seeds 11-14."""

from __future__ import annotations

import json

import pytest

import tmopt.mismatch.diagnose as diagnose_module
from tmopt.design import cli
from tmopt.design.plan import NOTHING, plan_from_diagnosis
from tmopt.design.problem import DesignSpace
from tmopt.mismatch import calibration as cal
from tmopt.mismatch.diagnose import diagnose
from tmopt.mismatch.effects import Injection
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generate import generate_recording
from tmopt.mismatch.report import build_report, write_report
from tmopt.physics.recording import read_recording, write_recording

CUBIC = Injection("cubic_stiffness", 12.0, "x1")
KEY = "cubic_stiffness[x1]"


def test_a_report_with_nothing_to_separate_says_so_in_one_line(tmp_path, capsys,
                                                               monkeypatch):  # fmt: skip
    """Neither a not-identifiable flag nor an ambiguous name with a rival a planned run
    can hold (a shape misfit is none): one line, exit 2, before the recording is read."""

    def boom(*a, **k):
        raise AssertionError("expensive work started before the report was checked")

    monkeypatch.setattr(diagnose_module, "fit_state", boom)
    rep = {"source": "absent.h5", "not_identifiable": [
        {"name": "glitch", "channel": "all", "reason": "untestable: no residual"}],
        "ambiguous": [{"name": "bias_drift", "channel": "x1", "parameters": {"b": 1e-13},
                       "rivals": [{"name": "shape misfit (its residual needs a curvature: "
                                           "not the effect's shape)", "channel": "x1",
                                   "delta_bic": None}]}]}  # fmt: skip
    path = tmp_path / "report.json"
    path.write_text(json.dumps(rep))
    assert cli.main([str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nothing to design for" in err[0] and NOTHING in err[0]
    assert not (tmp_path / "o").exists()



def test_a_report_whose_recording_is_not_a_file_says_so_in_one_line(tmp_path, capsys):
    """A report of a recording diagnosed in memory (source ``<memory>``) has no recording
    to take the noise level from: one line naming ``source``, not a reader's error about
    a file extension."""
    rep = {"source": "<memory>", "not_identifiable": [
        {"name": "stiffness_cross_coupling", "channel": "x1<-y1", "reason": "not excited",
         "plausible": 3e-7}]}  # fmt: skip
    path = tmp_path / "report.json"
    path.write_text(json.dumps(rep))
    assert cli.main([str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "source '<memory>'" in err[0] and "not a file" in err[0]
    assert not (tmp_path / "o").exists()

@pytest.mark.slow
@pytest.mark.parametrize("seed, reported", [(11, "ambiguous"), (13, "feature")])
def test_an_ambiguous_cubic_is_separated_by_the_design(tmp_path, seed, reported):
    """Seed 11: the cubic is selected, x|x| within the band (``ambiguous``); seed 13: x|x|
    is selected, the cubic within its band (a ``features`` entry's ``alternatives``)."""
    rec, _ = generate_recording([CUBIC], seed=seed, duration=600.0)
    write_recording(rec, tmp_path / "first.h5")
    dg = diagnose(data_from_recording(read_recording(tmp_path / "first.h5")))
    rep = build_report(dg)
    if reported == "ambiguous":
        amb = [a for a in rep["ambiguous"] if a["name"] == "cubic_stiffness"]
        assert amb and amb[0]["channel"] == "x1", rep["conclusion"]
        assert {r.get("feature") for r in amb[0]["rivals"]} & {"x|x| force", "f|f| actuation"}
    else:
        assert not rep["effects"] and not rep["ambiguous"], rep["conclusion"]
        assert any(f["feature"] == "x|x| force" and {"name": "cubic_stiffness", "channel": "x1"}
                   .items() <= a.items() for f in rep["features"]
                   for a in f.get("alternatives", [])), rep["features"]  # fmt: skip
    plan = plan_from_diagnosis(dg, DesignSpace(axes=("x1",), duration=(2400.0, 2400.0)),
                               effects=[KEY], algorithm="nsga2", pop_size=16, budget=64,
                               seed=1)  # fmt: skip
    (target,) = plan.problem.targets
    assert target.reason == "ambiguous" and target.rivals
    assert plan.feasible and plan.all_detectable
    # the expected delta-BIC gap to the rival at the diagnosis' selection step: inside
    # the ambiguity band before, beyond the detection threshold z^2 after
    gap = {k: (target.plausible / p.judged(KEY)) ** 2
           for k, p in (("before", plan.before), ("after", plan.after))}  # fmt: skip
    assert gap["before"] < cal.AMBIGUOUS_DBIC < plan.z**2 <= gap["after"]
    rec2, _ = generate_recording([CUBIC], seed=seed + 1, excitation=plan.spec,
                                 duration=plan.duration)  # fmt: skip
    rep2 = build_report(diagnose(data_from_recording(rec2)))
    named = [e for e in rep2["effects"] if e["name"] == "cubic_stiffness"]
    assert named and named[0]["channel"] == "x1", rep2["conclusion"]
    assert not rep2["ambiguous"], rep2["conclusion"]
    k3, sigma = named[0]["parameters"]["k3"], named[0]["uncertainties"]["k3"]
    assert abs(k3 - CUBIC.magnitude) < 3 * sigma
    # the command reads the ambiguous name and its rival from the report too
    if reported != "ambiguous":
        return
    write_report(dg, tmp_path / "rep", plots=False)
    out = tmp_path / "next"
    assert cli.main([str(tmp_path / "rep" / "report.json"), "--out", str(out), "--effects",
                     KEY, "--axes", "x1", "--tones", "1", "--algorithm", "nsga2",
                     "--pop-size", "4", "--generations", "1", "--duration", "2400,2400",
                     "--no-plots"]) == 0  # fmt: skip
    (t,) = json.loads((out / "next_excitation.json").read_text())["targets"]
    assert t["reason"] == "ambiguous" and t["rivals"] == target_rivals(target)
    assert "Separated from" in (out / "design.md").read_text()


def target_rivals(target) -> list[str]:
    return [r.key for r in target.rivals]
