"""The realistic benchmark's scorer and command line (experiments/mismatch_benchmark.py
--realistic): ``--only`` runs a chosen list of recordings; the second SNR sees what the
nominal fit leaves of an effect's signature."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture()
def bench(monkeypatch):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_benchmark
    import mismatch_realistic

    return mismatch_benchmark, mismatch_realistic


def test_only_picks_the_named_recordings_and_refuses_a_bad_item_in_one_line(bench, capsys):
    mb, mr = bench
    todo = [c for b in ("kernel", "foreign") for c in mr.cases(b, 40000, False)]
    got = {(c["backend"], c["seed"]) for c in mr.only(todo, "40036, foreign:40101")}
    assert got == {("kernel", 40036), ("foreign", 40036), ("foreign", 40101)}
    for bad in ("other:40036", "40x", ","):
        assert mb.main(["--realistic", "--only", bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--only" in err[0]


def test_only_runs_just_that_recording_smoke(bench, tmp_path):
    mb, _ = bench
    out = tmp_path / "bench"
    rc = mb.main(["--realistic", "--quick", "--jobs", "1", "--backend", "kernel",
                  "--only", "kernel:40000", "--out", str(out)])  # fmt: skip
    assert rc == 0
    rows = [json.loads(x) for x in (out / "realistic_rows.jsonl").read_text().splitlines()]
    assert [(r["backend"], r["seed"], r["truth"]) for r in rows] == [("kernel", 40000, "clean")]
    assert "traceback" not in rows[0] and rows[0]["snr_nominal"] == ""


def test_the_second_snr_is_blind_to_what_the_nominal_fit_absorbs(bench):
    """A change of the stiffness (the nominal model's own parameter) leaves no visible SNR;
    a drifting force on the same axis does (both as a mis-recorded force channel, so that
    only the equation group changes)."""
    _, mr = bench
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    sc = replace(draw_scenario(7, "kernel"), duration=1200.0, sample_rate=2.0)
    rec, _ = realistic_recording(sc, (), (), 7, "kernel")
    d0, basis = prepare(data_from_recording(rec))
    state = fit_state(d0, basis, [], [], False, Settings())
    dk = 0.2 * abs(float(d0.stiffness[0]))
    absorbed, _ = prepare(data_from_recording(rec))
    absorbed.force = absorbed.force.copy()  # the force channel: Eq. 10 only, not kinematics
    absorbed.force[0] -= dk * absorbed.x_eq[0]
    ramp, _ = prepare(data_from_recording(rec))
    ramp.force = ramp.force.copy()
    size = 20 * dk * float(np.std(d0.x_eq[0]))
    ramp.force[0] -= size * (ramp.time - ramp.time.mean()) / np.ptp(ramp.time)
    seen_k = mr.visible_snr(d0, basis, state, absorbed)
    seen_ramp = mr.visible_snr(d0, basis, state, ramp)
    assert seen_ramp > 10.0
    assert seen_k < 1e-6 * seen_ramp


def test_the_second_rate_keeps_the_scalers_snr_where_no_signature_can_be_projected(bench):
    """A noise-like effect (NaN second SNR) counts as the scaler saw it; a deterministic
    one the nominal fit hides (second SNR below 15) leaves the second rate's denominator."""
    _, mr = bench
    rep = {"effects": [{"name": "actuation_quantisation", "channel": "all axes"}],
           "not_identifiable": [], "mismatch_detected": True}  # fmt: skip
    truth = {"effects": [{"name": "actuation_quantisation"}, {"name": "actuation_gain"}],
             "snr": [30.0, 40.0], "snr_nominal": [float("nan"), 1.7]}  # fmt: skip
    row = mr.score(rep, truth)
    assert not row["attributed"]  # headline: the gain (scaler SNR 40) was not named
    assert row["n_identifiable_nominal"] == 1 and row["attributed_nominal"]


def _drift_report(channel: str) -> dict:
    return {"effects": [{"name": "bias_drift", "channel": channel}], "not_identifiable": [],
            "mismatch_detected": True, "unexplained": False}  # fmt: skip


def _ooc_truth(distinct: float, look_alike: str = "bias_drift[x1]") -> dict:
    return {"effects": [], "snr": [], "out_of_catalogue": [{"name": "bias_modulation",
                                                             "axis": "x1"}],
            "ooc_distinct": [{"visible": 30.0, "distinct": distinct,
                              "look_alike": look_alike}]}  # fmt: skip


def test_a_look_alike_the_data_cannot_tell_apart_is_excused_only_in_the_second_rate(bench):
    """A slow modulation whose signature a drift at x1 leaves at SNR 2.4 (below the
    identifiable 15): naming that drift is a wrong name in the headline and not in the
    second rate; a drift on another axis, or a look-alike the data *can* tell apart, or an
    unknown (NaN) limit stays wrong in both."""
    _, mr = bench
    row = mr.score(_drift_report("x1"), _ooc_truth(2.4))
    assert row["wrong"] and not row["wrong_distinct"]
    assert row["ooc_distinguishable"] is False
    for rep, truth in ((_drift_report("x2"), _ooc_truth(2.4)),
                       (_drift_report("x1"), _ooc_truth(40.0)),
                       (_drift_report("x1"), _ooc_truth(float("nan")))):  # fmt: skip
        row = mr.score(rep, truth)
        assert row["wrong"] and row["wrong_distinct"]
    assert mr.score(_drift_report("x1"), _ooc_truth(40.0))["ooc_distinguishable"] is True
    rows = [{"backend": "kernel", "category": "out-of-catalogue", "truth": "bias_modulation",
             "n_identifiable": 0, "extra_names": 1, "unexplained": False, "refused": False,
             **mr.score(_drift_report("x1"), _ooc_truth(d))} for d in (2.4, 40.0)]  # fmt: skip
    text = mr.summarise(rows)
    assert "| recordings with a wrong (extra) name | 2/2 (100 %)" in text
    assert "(second rate; 2 rows carry it) | 1/2 (50 %)" in text
    assert "(second rate; 1 of 2 are) | 0/1 (0 %)" in text


def test_a_flagged_channel_tie_is_excused_only_in_the_added_line(bench):
    """docs/mismatch.md 9.35's added line: a drift named on x2 whose report flags x1 as
    the channel barely chosen, beside a look-alike drift at x1 the data cannot tell from
    the truth, stays wrong in the headline and against the limit, and is not counted in
    the added line; a flagged alternative that is not the look-alike's channel, or a
    look-alike the data can tell apart, is counted in all three."""
    _, mr = bench

    def tied(alternatives):
        rep = _drift_report("x2")
        rep["effects"][0]["channel_alternatives"] = alternatives
        return rep

    row = mr.score(tied(["x1"]), _ooc_truth(2.4))
    assert row["wrong"] and row["wrong_distinct"] and not row["wrong_distinct_ties"]
    for rep, truth in ((tied(["y2"]), _ooc_truth(2.4)), (tied([]), _ooc_truth(2.4)),
                       (tied(["x1"]), _ooc_truth(40.0))):  # fmt: skip
        row = mr.score(rep, truth)
        assert row["wrong_distinct"] and row["wrong_distinct_ties"]
    rows = [{"backend": "foreign", "category": "out-of-catalogue", "truth": "thermal",
             "n_identifiable": 0, "extra_names": 1, "unexplained": False, "refused": False,
             **mr.score(tied(alt), _ooc_truth(2.4))} for alt in (["x1"], ["y2"])]  # fmt: skip
    text = mr.summarise(rows)
    assert "look-alike the data cannot tell from its out-of-catalogue truth not counted " \
        "(second rate; 2 rows carry it) | 2/2 (100 %)" in text
    assert "(added line, 9.35; 2 rows carry it) | 1/2 (50 %)" in text


def test_a_modulation_through_its_zero_crossing_is_a_drift_and_a_line_is_not(bench):
    """The physical limit itself (:func:`limits`), on a 1200 s record: a 1e-4 Hz
    modulation centred on its zero crossing (0.12 of a cycle) is within a few percent a
    ramp -- a drift takes almost all of it --; a force line at 0.05 Hz is nothing any
    catalogue effect can stand in for."""
    _, mr = bench
    from tmopt.mismatch.realistic import OOC, draw_scenario

    sc = replace(draw_scenario(7, "kernel"), duration=1200.0, sample_rate=2.0)
    mod = OOC("bias_modulation", 3e-12, "x1", {"phase": -2 * np.pi * 1e-4 * 600.0})
    line = OOC("unmodelled_line", 1e-12, "x1", {"f_hz": 0.05, "phase": 0.3})
    per_effect, (m, ln) = mr.limits(sc, [], [mod, line], 7, "kernel")
    assert per_effect == []
    assert m["visible"] > 15.0 and m["look_alike"].startswith("bias_drift")
    assert m["distinct"] < 0.1 * m["visible"]
    assert ln["visible"] > 15.0 and ln["distinct"] > 0.9 * ln["visible"]


def test_an_accelerometer_scale_cannot_stand_in_for_a_gain_its_twin_is_tied(bench):
    """Scored as the tool tests it: an accelerometer scale's Eq. 10 column spans a gain's
    ``g f`` once the stiffness is free, but the same parameter also moves the kinematic
    check (its tied twin), which a gain leaves alone -- so a gain stays distinct from it.
    Projected with the twin free, the scale would absorb the gain entirely."""
    _, mr = bench
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare
    from tmopt.mismatch.effects import CATALOGUE, Context, Injection
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    sc = replace(draw_scenario(7, "kernel"), duration=1200.0, sample_rate=2.0)
    gain = Injection("actuation_gain", 5e-4, "x1")
    d0, basis = prepare(data_from_recording(realistic_recording(sc, (), (), 7, "kernel")[0]))
    d1 = prepare(data_from_recording(realistic_recording(sc, [gain], (), 7, "kernel")[0]))[0]
    state = fit_state(d0, basis, [], [], False, Settings())
    groups = mr._changes(d0, basis, state, d1)
    scale = next(c for m in CATALOGUE for c in m.candidates(Context(d1, basis))
                 if c.key == "readout_scale[acc:x1]")  # fmt: skip
    visible = mr._snr_left(groups, [])
    tied = mr._snr_left(groups, mr._look_alike_columns(scale))
    free = mr._snr_left(groups, [{"equation": scale.columns[0]}, {"kinematic": scale.twin}])
    assert visible > 15.0
    assert tied > 0.5 * visible
    assert free < 0.05 * visible


def test_distinct_refuses_to_run_a_benchmark_in_one_line(bench, capsys):
    """``--distinct`` scores a finished run; asked to run one it says so and stops."""
    mb, _ = bench
    assert mb.main(["--realistic", "--distinct"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--distinct" in err[0] and "--summarise" in err[0]


def test_a_run_keeps_its_scaler_version_and_refuses_another(bench, tmp_path):
    """A run's recordings depend on the SNR scaler's version, so a run records it and a
    resume or re-score regenerates with it; a run from before the record is version 1."""
    _, mr = bench
    new, old = tmp_path / "new", tmp_path / "old"
    new.mkdir()
    assert mr._run_scaler(new, None, mr.provenance()) == 2
    meta = json.loads((new / "realistic_meta.json").read_text())
    assert meta["scaler_version"] == 2
    import tmopt  # the code that ran, so two arms of a paired run can be told apart

    assert meta["tmopt"] == str(Path(tmopt.__file__).resolve().parent)
    assert meta["commit"] and "torch" in meta["versions"]
    assert mr._run_scaler(new, 2, {}) == 2
    with pytest.raises(SystemExit, match="--scaler-version 1, but the run in .* version 2"):
        mr._run_scaler(new, 1, {})
    old.mkdir()
    (old / "realistic_rows.jsonl").write_text("")
    assert mr._run_scaler(old, None, {}) == 1
    assert all(c["scaler"] == 1 for c in mr.cases("foreign", 40000, True, 1))


def test_the_clean_calibration_counts_the_defaults_alarms_and_refuses_a_benchmark_seed(
        bench, capsys, monkeypatch):  # fmt: skip
    """``mismatch_calibration.py --realistic``: the full defaults' false alarms per
    simulator with what raised each; a seed base inside the benchmark's range is refused
    in one line before anything runs."""
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_calibration as mc

    assert mc.main(["--realistic", "--seed-base", "40000"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--seed-base" in err[0]
    raised = {"what": "curvature", "channel": "x2", "glr": 28.2, "p_holm": 0.0037,
              "delta_bic": 10.0, "trials": 1.0}  # fmt: skip
    rows = [{"backend": b, "seed": s, "refused": "", "min_p_holm": 0.5, "locate_p": 0.5,
             "false_alarm": False, "raised": []} for b in ("kernel", "foreign") for s in range(4)]
    rows[0].update(false_alarm=True, raised=[raised], min_p_holm=0.0037)
    text = mc.realistic_summary(rows)
    assert "| kernel | 1/4 | 0.250 |" in text and "| both | 1/8 | 0.125 |" in text
    assert "kernel 0: curvature[x2] GLR 28.2 p_holm 0.0037" in text


def test_setting_reads_the_tools_settings_and_refuses_a_bad_one_in_one_line(bench, capsys):
    """``--setting NAME=VALUE`` diagnoses with a non-default tool (an option scored on a
    never-seen draw without patching the code); a bad name or value is refused in one line
    naming it, before anything is simulated."""
    mb, mr = bench
    assert mr.parse_settings(["kin_profile=true", "alpha=0.02", "lowfreq=curvature"]) == {
        "kin_profile": True, "alpha": 0.02, "lowfreq": ("curvature",)}
    assert mr.parse_settings(None) == {}
    for bad, named in (("kin_profil=true", "kin_profil"), ("kin_profile=yes", "kin_profile"),
                       ("alpha=2", "alpha"), ("max_effects=x", "max_effects"),
                       ("rails", "rails")):  # fmt: skip
        assert mb.main(["--realistic", "--setting", bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--setting" in err[0] and named in err[0], err
    assert mb.main(["--setting", "kin_profile=true"]) == 2
    assert "--realistic" in capsys.readouterr().err


def test_a_run_keeps_its_settings_and_a_resume_must_ask_the_same(bench, tmp_path):
    """Settings are kept with the run, with every setting they come to; resuming with
    other effective settings would mix two tools in one table (refused), a summary reads
    what the run kept; a run from before they were kept ran the defaults of its code,
    which are not known, so it is not resumed."""
    from tmopt.mismatch.diagnose import Settings

    _, mr = bench
    new, old, older = tmp_path / "new", tmp_path / "old", tmp_path / "older"
    new.mkdir()
    mr._run_scaler(new, None, {})
    off = {"onset_profile": False, "kin_profile": False}
    assert mr._run_settings(new, {"kin_profile": False}, True) == {"kin_profile": False}
    meta = json.loads((new / "realistic_meta.json").read_text())
    assert meta["settings"] == {"kin_profile": False} and meta["scaler_version"] == 2
    assert meta["effective"]["kin_profile"] is False and meta["effective"]["alpha"] > 0
    assert meta["effective"]["lowfreq"] == list(Settings().lowfreq)
    assert mr._run_settings(new, {"kin_profile": False}, True) == {"kin_profile": False}
    # the same tool asked another way (onset_profile's default said out loud) is no mix
    assert mr._run_settings(new, off, True) == off
    with pytest.raises(SystemExit, match="runs the tool with kin_profile=True, but .* "
                                         "made with kin_profile=False; use another"):
        mr._run_settings(new, {}, True)
    assert mr._run_settings(new, {}, False) == {"kin_profile": False}
    # a default changed after a run was made: the run keeps what it ran
    meta["effective"]["onset_profile"] = True
    (new / "realistic_meta.json").write_text(json.dumps(meta))
    with pytest.raises(SystemExit, match="onset_profile=False, but .* onset_profile=True"):
        mr._run_settings(new, {"kin_profile": False}, True)
    for run, kept in ((old, {"scaler_version": 2, "commit": "02566d4"}),
                      (older, {"scaler_version": 2, "settings": {}})):
        run.mkdir()
        (run / "realistic_rows.jsonl").write_text("")
        (run / "realistic_meta.json").write_text(json.dumps(kept))
        with pytest.raises(SystemExit, match="did not keep the settings it ran with"):
            mr._run_settings(run, {}, True)
    assert mr._run_settings(old, {}, False) == {} and mr._run_settings(older, {}, False) == {}
    # an old run's record is not rewritten with settings it never recorded
    assert "settings" not in json.loads((old / "realistic_meta.json").read_text())


def test_a_case_is_diagnosed_with_the_runs_settings(bench, monkeypatch):
    """The settings reach the diagnosis of every case (not only the run's record)."""
    _, mr = bench
    import tmopt.mismatch.diagnose as dg

    seen = []

    def fake(data, settings=None):
        seen.append(settings)
        raise RuntimeError("stop here")

    monkeypatch.setattr(dg, "diagnose", fake)
    [case] = [c for c in mr.cases("kernel", 40000, True) if c["seed"] == 40000]
    mr.run_case({**case, "settings": {"kin_profile": False}})
    mr.run_case(case)
    assert seen[0] == dg.Settings(kin_profile=False) and seen[1] is None


def test_a_calibration_nulls_rows_stream_and_resume(bench, tmp_path, capsys):
    """``per_recording`` (the nulls of experiments/mismatch_*_null and *_profile): one
    row per recording of both simulators, streamed; a rerun skips what is there."""
    _, mr = bench
    out = tmp_path / "null.jsonl"
    calls = []

    def job(b, seed, i):
        calls.append((b, seed))
        return {"value": seed * 2}

    mr.per_recording(37000, 2, out, job, lambda row: f"{row['backend']} {row['seed']}")
    assert calls == [("kernel", 37000), ("foreign", 37000), ("kernel", 37001),
                     ("foreign", 37001)]  # fmt: skip
    assert capsys.readouterr().out.splitlines()[0] == "kernel 37000"
    mr.per_recording(37000, 3, out, job)
    assert calls[4:] == [("kernel", 37002), ("foreign", 37002)]
    rows = [json.loads(x) for x in out.read_text().splitlines()]
    assert [(r["backend"], r["seed"], r["value"]) for r in rows][-1] == ("foreign", 37002, 74004)
    assert len(rows) == 6 and mr.rows_done(out) == {(b, s) for b in ("kernel", "foreign")
                                                    for s in (37000, 37001, 37002)}
