"""Honest attribution on flight-like recordings (issue 26, part 5): physics the catalogue
lacks is reported *unexplained* at the right axis, never under the catalogue name that
happens to absorb part of it.

Before the nonlinear-force and product features (tmopt/mismatch/generic.py), a force
``kappa x|x|`` and a quadratic stiffness ``k2 x^2`` were named ``cubic_stiffness`` and an
``x*y`` product coupling ``stiffness_cross_coupling`` + ``sensing_cross_talk`` (docs/
mismatch.md 9.7).  The recordings are development seeds (< 20000) of both simulators,
never the benchmark's (40000 on); the effects are scaled to SNR 40 in each recording's
own noise, as in the benchmark.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tmopt.mismatch.diagnose import Settings, diagnose
from tmopt.mismatch.effects import Injection
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generate import MAGNITUDES
from tmopt.mismatch.realistic import (
    OUT_OF_CATALOGUE,
    draw_scenario,
    make_ooc,
    realistic_recording,
    scale_to_snr,
)
from tmopt.mismatch.report import build_report

SNR = 40.0


def _report(backend: str, seed: int, effects=(), ooc=(), settings=None) -> dict:
    rec, _ = realistic_recording(draw_scenario(seed, backend), list(effects), list(ooc), seed,
                                 backend)  # fmt: skip
    return build_report(diagnose(data_from_recording(rec), settings))


def _ooc(name: str, axis: str, backend: str, seed: int):
    sc = draw_scenario(seed, backend)
    o = make_ooc(name, OUT_OF_CATALOGUE[name].trial, axis, seed, sc)
    return scale_to_snr(sc, o, SNR, seed, backend)[0]


@pytest.mark.parametrize(("name", "backend", "seed", "axis"), [
    pytest.param("position_abs", "kernel", 501, "x2", marks=pytest.mark.slow),  # 23 s
    pytest.param("quadratic_stiffness", "kernel", 503, "x2", marks=pytest.mark.slow),  # 37 s
    pytest.param("xy_product", "kernel", 505, "x2", marks=pytest.mark.slow),  # 8 s
    ("position_abs", "foreign", 502, "x1"),
])  # fmt: skip
def test_nonlinear_and_product_forces_are_unexplained_not_named(name, backend, seed, axis):
    rep = _report(backend, seed, ooc=[_ooc(name, axis, backend, seed)])
    assert rep["status"] == "diagnosed", rep["reason"]
    assert not rep["effects"], rep["conclusion"]
    assert rep["unexplained"], rep["conclusion"]
    assert any(f["channel"] == axis for f in rep["features"]), rep["features"]
    assert axis in rep["unexplained_at"]["channels"], rep["unexplained_at"]


@pytest.mark.parametrize(("backend", "seed", "axis"), [("kernel", 509, "x1"),
                                                       pytest.param("foreign", 510, "x2",
                                                                    marks=pytest.mark.slow)])
def test_a_true_cubic_stiffness_keeps_its_name(backend, seed, axis):
    """The new features must not take a catalogue effect's place where it fits."""
    sc = draw_scenario(seed, backend)
    inj = Injection("cubic_stiffness", MAGNITUDES["cubic_stiffness"]["large"], axis)
    inj = scale_to_snr(sc, inj, SNR, seed, backend)[0]
    rep = _report(backend, seed, effects=[inj])
    assert [(e["name"], e["channel"]) for e in rep["effects"]] == [("cubic_stiffness", axis)], \
        rep["conclusion"]  # fmt: skip


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_large_delay_with_a_drift_gets_both_names():
    """The issue's foreign-simulator case (a 0.2 s actuation delay with a bias drift, once
    reported as the drift alone), on the independent simulator: both are named, nothing
    else is (a regression test: the current selection already finds both; a joint search
    over pairs was not needed for it)."""
    backend, seed = "foreign", 514
    sc = draw_scenario(seed, backend)
    drift = Injection("bias_drift", MAGNITUDES["bias_drift"]["large"], "x1")
    drift = scale_to_snr(sc, drift, 20.0, seed, backend)[0]
    rep = _report(backend, seed, effects=[Injection("actuation_delay", 0.2, "x1"), drift])
    names = sorted((e["name"], e["channel"]) for e in rep["effects"])
    assert names == [("actuation_delay", "x1"), ("bias_drift", "x1")], rep["conclusion"]


@pytest.mark.parametrize(("seed", "axis", "snr"), [(501, "x2", 170.0), (502, "x1", 60.0)])
def test_the_dac_step_is_found_to_the_precision_its_sawtooth_needs(seed, axis, snr):
    """The quantisation search on the independent simulator: q to ~1e-5 of itself, so no
    command in the force range (hundreds of steps) is rounded to the wrong side -- each
    such sample was a one-sample spike of a whole step, under a steep coloured noise
    model a whitened outlier read as a glitch.  Before: seed 501's q was 2e-4 off (three
    'glitches' left beside it; benchmark r3: an extra glitch name 2 of 2), and seed 502's
    q (1.26e-9, above the old search range of 1e-9) was found as q/2 (gain 1.32 and a
    wrong actuation delay named beside it)."""
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare
    from tmopt.mismatch.effects import EFFECTS, Context

    backend = "foreign"
    sc = draw_scenario(seed, backend)
    inj = Injection("actuation_quantisation", MAGNITUDES["actuation_quantisation"]["large"],
                    axis)  # fmt: skip
    inj = scale_to_snr(sc, inj, snr, seed, backend)[0]
    rec, truth = realistic_recording(sc, [inj], [], seed, backend)
    data, basis = prepare(data_from_recording(rec))
    state = fit_state(data, basis, [], [], False, Settings())
    q, _ = EFFECTS["actuation_quantisation"].search(
        Context(data, basis, state.eq_fit.residual, state.eq_noise))
    q_true = truth["effects"][0]["parameters"]["q"]
    # what the precision is for: across the force range (max |u|/q steps) q's relative
    # error accumulates to a fraction of one step, which must stay small (< 1 %) for the
    # sawtooth to be right at every command.  (The former bound, 3e-5 relative, passed in
    # CI at 565ad3a and failed at the same commit in a fresh environment with the locked
    # library versions (stop 35; floating-point order): seed 502 gave 4.1e-5, i.e. 0.2 %
    # of a step over its 46 steps, and the full diagnosis still names the quantisation
    # alone.  Seed 501's old 2e-4 over 186 steps is 3.7 %: still a failure.)
    steps = float(np.nanmax(np.abs(data.force))) / q_true
    assert abs(q / q_true - 1) * steps < 0.01, (q, q_true, steps)


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_slow_curved_bias_change_is_not_named_a_linear_drift():
    """A 1e-4 Hz bias modulation over a 40-minute record: mostly a ramp, but its curved
    part is above the noise, so the drift's shape check (Legendre P2 + P3 of time in the
    final model, :meth:`BiasDrift.shape_check`) leaves the name ambiguous and the channel
    unexplained.  Before: ``bias_drift [x2]`` with confidence (benchmark r3: 5 of 5
    modulations named so, or ambiguous with no channel unexplained)."""
    backend, seed, axis = "kernel", 512, "x2"
    rep = _report(backend, seed, ooc=[_ooc("bias_modulation", axis, backend, seed)])
    assert not rep["effects"], rep["conclusion"]
    assert axis in rep["unexplained_at"]["channels"], rep["unexplained_at"]


def test_a_stiffness_step_is_not_named_a_linear_stiffness_drift():
    """A stiffness step halfway through the record (kernel, development seed 621, SNR 40):
    the catalogue's stiffness drift takes its linear part; the drift's shape check
    (Legendre P2 + P3 of time times x2, :meth:`StiffnessDrift.shape_check`) finds the rest
    and leaves the name ambiguous, the channel unexplained.  Before: ``stiffness_drift
    [x2]`` with confidence (the benchmark's 140000 set: k140129, k140131)."""
    backend, seed, axis = "kernel", 621, "x2"
    rep = _report(backend, seed, ooc=[_ooc("stiffness_step", axis, backend, seed)])
    assert not rep["effects"], rep["conclusion"]
    assert axis in rep["unexplained_at"]["channels"], rep["unexplained_at"]
    drift = [a for a in rep["ambiguous"] if a["name"] == "stiffness_drift"]
    assert drift and any(r["name"].startswith("shape misfit") for r in drift[0]["rivals"]), \
        rep["ambiguous"]  # fmt: skip


@pytest.mark.parametrize(("backend", "seed", "axis"), [
    pytest.param("kernel", 641, "x2", marks=pytest.mark.slow), ("foreign", 644, "x1")])  # 19 s, 8 s
def test_a_true_linear_stiffness_drift_keeps_its_name(backend, seed, axis):
    """The stiffness drift's shape check must not take a linear drift's name (SNR 20);
    its false-misfit rate is measured by ``experiments/mismatch_shape_calibration.py
    --effect stiffness_drift`` (docs/mismatch.md 9.16)."""
    sc = draw_scenario(seed, backend)
    inj = Injection("stiffness_drift", MAGNITUDES["stiffness_drift"]["large"], axis)
    rep = _report(backend, seed, effects=[scale_to_snr(sc, inj, 20.0, seed, backend)[0]])
    assert [(e["name"], e["channel"]) for e in rep["effects"]] == [("stiffness_drift", axis)], \
        rep["conclusion"]  # fmt: skip


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_thermal_relaxation_is_unexplained_not_glitches_or_a_drift():
    """A force relaxing exponentially to a new level (tau 100-600 s), on the independent
    simulator: the relaxation feature (onset and tau searched around the best steps)
    reports it unexplained at its axis.  Before: three glitches or a bias drift (benchmark
    r3: foreign 2 of 3 relaxations named so).  Studied with the accelerometer convention
    read as before stop 56; the default's outcome beside it."""
    backend, seed, axis = "foreign", 522, "x2"
    ooc = [_ooc("thermal_relaxation", axis, backend, seed)]
    # the mechanism, on the convention read before stop 56 (held; recorded mean)
    rep = _report(backend, seed, ooc=ooc, settings=Settings(convention_profile=False))
    assert rep["data_used"]["acc_convention"] == "held"
    assert not rep["effects"], rep["conclusion"]
    assert axis in rep["unexplained_at"]["channels"], rep["unexplained_at"]
    assert any(f["feature"] == "relaxation" and f["channel"] == axis
               for f in rep["features"]), rep["features"]  # fmt: skip
    # the default reads the recorded mean (docs/mismatch.md 9.32); the step's GLR then
    # rises more than the relaxation's (33.3 -> 41.6 against 42.1 -> 45.1) and the step
    # wins on its p-value: the same outcome -- no name, unexplained at its axis -- with
    # the shape reported as a lasting step
    rep = _report(backend, seed, ooc=ooc)
    assert rep["data_used"]["acc_convention"] == "mean"
    assert not rep["effects"], rep["conclusion"]
    assert axis in rep["unexplained_at"]["channels"], rep["unexplained_at"]
    assert any(f["feature"] in ("relaxation", "step") and f["channel"] == axis
               for f in rep["features"]), rep["features"]  # fmt: skip


def test_a_loud_glitch_on_the_independent_simulator_is_one_named_event():
    """A shapelet glitch at SNR 60 starting between samples, on the independent simulator
    (development seed 531, 2.5 Hz): one confident ``glitch [x1]``, its kick within three
    of its reported errors, and that error the ~1/60 an SNR of 60 allows.
    Before: four glitch pieces, all ambiguous ("unexplained structure left"; benchmark
    r4: foreign glitch recordings 2 of 4, glitch + drift pairs 0 of 2).  (Until scaler
    version 2 this recording, stamped 'previous', was scaled 362x louder than SNR 60 and
    the kick was asserted to 1 %; at SNR 60 the report's own error is 1.5 %.)"""
    backend, seed = "foreign", 531
    sc = draw_scenario(seed, backend)
    inj = Injection("glitch", MAGNITUDES["glitch"]["large"], "x1",
                    options={"beta": 5.0, "shape": "shapelet"})  # fmt: skip
    inj = scale_to_snr(sc, inj, 60.0, seed, backend)[0]
    rep = _report(backend, seed, effects=[inj])
    assert [(e["name"], e["channel"]) for e in rep["effects"]] == [("glitch", "x1")], \
        rep["conclusion"]  # fmt: skip
    assert not rep["ambiguous"], rep["conclusion"]
    dv, sigma = rep["effects"][0]["parameters"]["dv"], rep["effects"][0]["uncertainties"]["dv"]
    assert abs(dv - inj.magnitude) < 3 * sigma
    assert sigma / abs(inj.magnitude) < 2.5 / 60


def _clipped_x2():
    """The x2 accelerometer clipped at 80 % of its range (out of catalogue)."""
    import copy

    from tmopt.mismatch.fit import data_from_result
    from tmopt.physics import SimulationConfig, simulate

    from .test_diagnose import REF1, REF2

    d = copy.deepcopy(data_from_result(simulate(REF1, REF2, SimulationConfig(duration=600.0),
                                                seed=31)))  # fmt: skip
    lim = 0.8 * np.nanmax(np.abs(d.acc[1]))
    d.acc[1] = np.clip(d.acc[1], -lim, lim)
    return d


@pytest.fixture(scope="module")
def clipped() -> dict:
    """Its report (by default: the rail samples read as measurements, since reading them
    does not refuse it)."""
    from tmopt.mismatch.report import build_report

    return build_report(diagnose(_clipped_x2()))


def test_a_clipped_accelerometer_masked_leaves_the_rest_consistent():
    """The same recording with its rail samples left out as gaps (``rails="mask"``,
    docs/mismatch.md 9.22): the rest is consistent with the model -- no name, no
    feature --, the saturation itself is the mismatch, unexplained at x2, and the report
    says how many samples were left out."""
    from tmopt.mismatch.diagnose import Settings
    from tmopt.mismatch.fit import drop_samples
    from tmopt.mismatch.plausibility import rail_samples

    data = _clipped_x2()
    rail = rail_samples(data)
    assert rail.sum() >= 10
    rep = build_report(diagnose(data, Settings(rails="mask")))
    assert rep["status"] == "diagnosed", rep.get("reason")
    assert not rep["effects"] and not rep["features"] and not rep["ambiguous"], \
        rep["conclusion"]  # fmt: skip
    assert rep["unexplained"] and rep["unexplained_at"]["channels"] == ["x2"]
    assert f"acc_x2 saturated ({int(rail.sum())} samples at its rail)" in rep["conclusion"]
    used = rep["data_used"]
    assert used["samples_left_out"] >= rail.sum()
    assert used["samples_used"] == data.n - used["samples_left_out"]
    # the left-out samples are gaps: no segment holds a rail sample, none crosses one
    kept = drop_samples(data, rail, "test")
    assert kept.n == used["samples_used"]
    assert not np.isin(kept.time, data.time[rail]).any()
    for a, b in kept.segments:
        assert np.allclose(np.diff(kept.time[a:b]), data.dt)


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_recording_refused_for_its_clipped_samples_is_diagnosed_without_them(monkeypatch):
    """Benchmark recording foreign 170137 (a set already read, eighteenth run): acc_x2
    clipped at its 90 % quantile.  Read as measurements, the clipped samples make the best
    explanation beyond physics twice over and the recording was refused.  By default
    (``rails="fallback"``) it is then diagnosed again with them left out: no name, x2
    unexplained, and the note says why."""
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[2] / "experiments"))
    import mismatch_realistic as mr

    rec, truth = mr.case_recording("foreign", 170137)
    assert [o["name"] for o in truth["out_of_catalogue"]] == ["acc_clipping"]
    rep = build_report(diagnose(data_from_recording(rec)))
    assert rep["status"] == "diagnosed", rep.get("reason")
    assert any("diagnosed again with them left out" in n and "cannot diagnose" in n
               for n in rep["notes"]), rep["notes"]  # fmt: skip
    assert rep["data_used"]["rails_left_out_after"] == "refusal"
    assert not rep["effects"], rep["conclusion"]
    assert "x2" in rep["unexplained_at"]["channels"]
    assert "acc_x2 saturated" in rep["conclusion"]


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_clipped_accelerometer_read_as_measured_is_unexplained_at_its_axis(clipped):
    """Out of catalogue: the x2 accelerometer clipped at 80 % of its range, its rail
    samples read as measurements (``rails="fallback"``: reading them does not refuse it).  The best
    catalogue fit was a "readout scale" of ~1e4 -- beyond physics; before, the whole
    recording was refused for it.  That explanation was then taken out, the rest selected
    again, and x2 reported unexplained with no confident name there.  On the true position
    (docs/mismatch.md 9.19) the clipped accelerometer's error enters x2's true-position
    estimate, three stiffness-shaped features on x2 come first, and the accelerometer
    scale left (e = 0.058) is ambiguous with the saturation: x2 is still unexplained with
    no name there, and the saturation is said."""
    rep = clipped
    assert rep["status"] == "diagnosed", rep.get("reason")
    assert rep["unexplained"] and "x2" in rep["unexplained_at"]["channels"]
    assert not [e for e in rep["effects"] if "x2" in e["channel"] or e["channel"] == "all axes"]
    assert "saturated acc_x2" in rep["conclusion"]  # the rival every name gets


def _diagnosed_with_one_name_beyond_physics(monkeypatch, afresh: bool) -> tuple[dict, int]:
    """A recording with a large x2 gain whose first selected effect is declared beyond
    physics once (so the selection reruns without it, as it does when a fit needs a
    physically impossible value): its report, and how many tests the rerun took from the
    first run's memo.  ``afresh``: every state tested anew instead.

    Why a declared rather than a found one: which real recording draws a name beyond
    physics moves with the noise model (the clipped x2 accelerometer above did until
    stop 47's estimate, docs/mismatch.md 9.23); the memo's contract does not."""
    import copy

    import tmopt.mismatch.diagnose as dg
    from tmopt.mismatch.fit import data_from_result
    from tmopt.mismatch.report import build_report
    from tmopt.physics import SimulationConfig, simulate

    from .test_diagnose import REF1, REF2
    from .test_effects import add_force

    d = copy.deepcopy(data_from_result(simulate(REF1, REF2, SimulationConfig(duration=600.0),
                                                seed=31)))  # fmt: skip
    add_force(d, 1, 4e-2 * d.force[1])
    real, flagged = dg._implausible, []

    def once(state, selected):
        if selected and not flagged:
            flagged.append(selected[0][0].candidate.key)
            return selected[0][0].candidate, "declared beyond physics by the test"
        return real(state, selected)

    memos = []
    init = dg._Evaluations.__init__

    def remember(self, *args):
        init(self, *args)
        memos.append(self)

    with monkeypatch.context() as mp:
        mp.setattr(dg, "_implausible", once)
        mp.setattr(dg._Evaluations, "__init__", remember)
        if afresh:
            mp.setattr(dg._Evaluations, "__call__", lambda self, state, exclude: dg.evaluate(
                self.data, self.basis, state, self.settings, exclude))  # fmt: skip
        rep = build_report(dg.diagnose(d))
    assert flagged, "no effect was selected: the rerun was not exercised"
    return rep, sum(m.reused for m in memos)


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_the_rerun_after_a_name_beyond_physics_reuses_tests_and_says_the_same(monkeypatch):
    """The selection rerun (a name beyond physics taken out) takes the tests of the states
    it passes through again from the first run's memo (diagnose._Evaluations): the memo
    must have served something (else it buys nothing) and the report must be exactly the
    one of testing every state afresh."""
    import json

    rep, reused = _diagnosed_with_one_name_beyond_physics(monkeypatch, afresh=False)
    assert reused > 0
    fresh, _ = _diagnosed_with_one_name_beyond_physics(monkeypatch, afresh=True)
    assert json.dumps(fresh, sort_keys=True, default=str) == \
        json.dumps(rep, sort_keys=True, default=str)  # fmt: skip


@pytest.mark.parametrize(("name", "seed", "axis"), [
    pytest.param("actuation_abs", 40125, "x2", marks=pytest.mark.slow),
    pytest.param("xy_product", 50114, "x2", marks=pytest.mark.slow),
])  # fmt: skip
def test_a_coupling_beside_a_nonlinear_force_on_its_axis_is_not_named(name, seed, axis):
    """Benchmark recordings of the read sets (kernel): ``u|u|`` and ``x2*y2`` on x2 were
    reported as their features *and* a named ``sensing_cross_talk`` touching x2 (y2<-x2,
    x2<-y2; docs/mismatch.md 9.10): the coupling is now ambiguous beside the feature."""
    backend = "kernel"
    rep = _report(backend, seed, ooc=[_ooc(name, axis, backend, seed)])
    assert not rep["effects"], rep["conclusion"]
    assert any(f["channel"] == axis for f in rep["features"]), rep["features"]
    assert axis in rep["unexplained_at"]["channels"], rep["unexplained_at"]


def test_a_name_beyond_physics_the_final_model_no_longer_wants_is_withdrawn(monkeypatch):
    """Benchmark recording foreign 110102 (twelfth run): a displacement readout scale
    (7e-5) beside a cubic stiffness on x2.  At one step an accelerometer scale of -162 took
    the lead from the displacement scale by 0.7 in dBIC, an actuation gain of -1 followed
    to undo it; taken out as beyond physics, the rerun named the truth, yet both names
    were left ambiguous beside it.  Tested again on the final model it is not wanted, so
    it is withdrawn with a note -- while a clipped accelerometer's stays (above).  That path
    is taken with ``kin_profile`` off (the default until stop 55); with it on (the default
    since) the same two true names come without an accelerometer scale to withdraw."""
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[2] / "experiments"))
    import mismatch_realistic as mr

    case = next(c for c in mr.cases("foreign", 110000, False) if c["seed"] == 110102)
    sc, effects, ooc, _ = mr.build(case)
    rec, _ = realistic_recording(sc, effects, ooc, 110102, "foreign")
    truth = {("cubic_stiffness", "x2"), ("readout_scale", "disp:x2")}
    for settings in (Settings(kin_profile=False), Settings()):
        rep = build_report(diagnose(data_from_recording(rec), settings))
        named = {(e["name"], e["channel"]) for e in rep["effects"]}
        assert named == truth, (settings.kin_profile, rep["conclusion"])
        assert not rep["ambiguous"] and not rep["unexplained"], rep["conclusion"]
        withdrawn = any("readout_scale[acc:x2]" in n and "no longer wants it" in n
                        for n in rep["notes"])  # fmt: skip
        assert withdrawn is not settings.kin_profile, rep["notes"]


@pytest.mark.parametrize(("backend", "seed"), [
    ("kernel", 513), pytest.param("foreign", 514, marks=pytest.mark.slow)])  # fmt: skip
def test_a_late_displacement_readout_is_an_unexplained_timing_at_its_readout(backend, seed):
    """Out of catalogue: the x1 readout stamped tau late (the generator interpolates the
    true motion: an independent path from the feature's tone-by-tone derivative).  It is
    reported as an unexplained ``readout timing`` on "x1 readout", no name, with the
    fitted offset within 25 % of the truth (SNR 40: a few per cent statistical)."""
    o = _ooc("readout_timing", "x1", backend, seed)
    rep = _report(backend, seed, ooc=[o])
    assert not rep["effects"], rep["conclusion"]
    got = [f for f in rep["features"] if f["feature"] == "readout timing"]
    assert [f["channel"] for f in got] == ["x1 readout"], rep["features"]
    assert "x1 readout" in rep["unexplained_at"]["channels"], rep["unexplained_at"]
    assert got[0]["fitted"]["tau"]["value"] == pytest.approx(o.magnitude, rel=0.25)


@pytest.mark.slow  # a diagnosis study of 12-60 s: CI's 15 min (`make test-slow`)
def test_a_refusal_after_names_beyond_physics_keeps_their_notes(monkeypatch):
    """Nothing said is lost: when a recording is refused for a third explanation beyond
    physics, the two taken out before it are still named in the notes (every selected
    effect is made to look implausible here, on a recording with a large x2 gain)."""
    import copy

    import tmopt.mismatch.diagnose as dg
    from tmopt.mismatch.fit import data_from_result
    from tmopt.physics import SimulationConfig, simulate

    from .test_diagnose import REF1, REF2
    from .test_effects import add_force

    d = copy.deepcopy(data_from_result(simulate(REF1, REF2, SimulationConfig(duration=600.0),
                                                seed=31)))  # fmt: skip
    add_force(d, 1, 4e-2 * d.force[1])

    def always(state, selected):
        if not selected:
            return None
        cand = selected[0][0].candidate
        return cand, f"cannot diagnose: {cand.key} made implausible by the test"

    monkeypatch.setattr(dg, "_implausible", always)
    rep = build_report(dg.diagnose(d))
    assert rep["status"] == "cannot_diagnose", rep.get("conclusion")
    said = [n for n in rep["notes"] if n.startswith("not named: ")]
    assert len(said) == dg.MAX_IMPLAUSIBLE and all("made implausible" in n for n in said)
