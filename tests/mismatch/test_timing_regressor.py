"""The readout timing feature's band regressor (``Settings.timing_regressor``,
docs/mismatch.md 9.34).

A displacement readout stamped ``tau`` late leaves ``-tau d/dt`` of the accelerometer term
in the kinematic residual.  The shipped regressor keeps only that term's excitation-tone
part; most of a late stamp's signature can lie in the motion the noise drives (benchmark
kernel 340140: distinct SNR 20.4, 6.0 of it in the tone part).  ``"band"`` uses the
measured term's derivative below the excitation's band (above it the loop's reply to the
readout noise makes the measured term endogenous).  The recordings are development seeds
(< 20000) of the flight-like generator, which stamps the readout late by interpolating
the true motion (an independent path from either regressor).
"""

from __future__ import annotations

import numpy as np
import pytest

from tmopt.mismatch import generic
from tmopt.mismatch.diagnose import Settings, diagnose, fit_state, prepare, residual_groups
from tmopt.mismatch.effects.base import Context
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generic import band_cutoff, band_derivative, central_derivative
from tmopt.mismatch.realistic import (
    OUT_OF_CATALOGUE,
    draw_scenario,
    make_ooc,
    realistic_recording,
    scale_to_snr,
)
from tmopt.mismatch.report import build_report

SEED = 543  # kernel, 4 Hz, 3428 s: the tone part holds a small share of a late stamp


def test_central_derivative_is_a_sine_s_slope_and_zero_at_a_segment_edge():
    dt, w = 0.5, 2 * np.pi * 0.05
    rows = np.r_[np.arange(0, 100), np.arange(110, 200)]  # a gap of 10 samples
    t = rows * dt
    got = central_derivative(np.sin(w * t), rows, dt)
    edges = np.isin(rows, [0, 99, 110, 199])
    assert np.all(got[edges] == 0.0)
    # the central difference's own error: w cos(wt) (sin(wh)/(wh) - 1), below (wh)^2/6
    assert np.allclose(got[~edges], w * np.cos(w * t[~edges]), rtol=0, atol=w * (w * dt) ** 2 / 6)


def test_an_unknown_regressor_is_refused_in_one_line_naming_it():
    with pytest.raises(ValueError, match="timing_regressor must be one of tones, band"):
        Settings(timing_regressor="spline")
    assert Settings().timing_regressor == "tones"  # the shipped default until 9.34 decides


def test_the_band_keeps_what_lies_below_its_cutoff_and_drops_what_lies_above():
    dt = 0.25
    rows = np.r_[np.arange(1, 3000), np.arange(3010, 3020)]  # a long segment, a short one
    bounds = ((0, 2999), (2999, 3009))
    t = rows * dt
    slow, fast = 2 * np.pi * 0.01, 2 * np.pi * 0.5
    got = band_derivative(np.sin(slow * t) + np.sin(fast * t), rows, bounds, dt, 0.05)
    inner = slice(300, 2700)  # away from the segment's edges
    assert np.allclose(got[inner], slow * np.cos(slow * t[inner]), atol=1e-3 * slow)
    assert np.all(got[2999:] == 0.0)  # too short to filter: left out
    assert band_cutoff([0.002, 0.03], 4.0) == pytest.approx(0.045)  # 1.5 x the highest tone
    assert band_cutoff([0.8], 2.0) == pytest.approx(0.5)  # at most a quarter of fs


def _recording(snr: float | None):
    sc = draw_scenario(SEED, "kernel")
    oo = []
    if snr is not None:
        o = make_ooc("readout_timing", OUT_OF_CATALOGUE["readout_timing"].trial, "x1", SEED, sc)
        oo = [scale_to_snr(sc, o, snr, SEED, "kernel")[0]]
    return realistic_recording(sc, [], oo, SEED, "kernel")[0], oo


def _first_step(rec) -> dict[str, tuple[float, float, float]]:
    """Per regressor: the x1 timing column's (estimate, sigma, GLR) against the nominal fit."""
    data, basis = prepare(data_from_recording(rec))
    state = fit_state(data, basis, [], [], False, Settings())
    group = residual_groups(data, state)["kinematic"]
    ctx = Context(data, basis, state.eq_fit.residual, state.eq_noise)
    out = {}
    for reg in generic.TIMING_REGRESSORS:
        [cand] = [c for c in generic._readout_timings(ctx, reg) if c.channel == "x1 readout"]
        out[reg] = (*group.estimate(cand.columns[0]), group.glr(cand.columns))
    return out


def test_the_band_regressor_sees_a_late_stamp_better_and_nothing_on_a_clean_record():
    """SNR 25: both estimates within 3 sigma of the truth, the band one's sigma under 0.6
    of the tone part's and its GLR over three times as large (5.5 -> 102 when written).
    The same recording without the late stamp: the band column's t-value within 3."""
    rec, [o] = _recording(25.0)
    got = _first_step(rec)
    for value, sigma, _ in got.values():
        assert abs(value - o.magnitude) < 3 * sigma, (got, o.magnitude)
    assert got["band"][1] < 0.6 * got["tones"][1], got
    assert got["band"][2] > 3 * got["tones"][2], got
    clean = _first_step(_recording(None)[0])
    value, sigma, _ = clean["band"]
    assert abs(value / sigma) < 3, clean


@pytest.mark.slow  # two diagnoses of a 3428 s record
def test_a_late_stamp_is_reported_with_the_band_regressor_only():
    """SNR 25: the tone part leaves it below the selection's level (nothing reported), the
    band reports it at its readout, unexplained, with no name."""
    rec, [o] = _recording(25.0)
    data = data_from_recording(rec)
    tones = build_report(diagnose(data, Settings()))
    assert not tones["features"] and not tones["effects"], tones["conclusion"]
    band = build_report(diagnose(data, Settings(timing_regressor="band")))
    assert not band["effects"], band["conclusion"]
    got = [f for f in band["features"] if f["feature"] == generic.TIMING]
    assert [f["channel"] for f in got] == ["x1 readout"], band["features"]
    assert "x1 readout" in band["unexplained_at"]["channels"]
    assert got[0]["fitted"]["tau"]["value"] == pytest.approx(o.magnitude, rel=0.3)


def test_the_timing_null_probe_refuses_an_unknown_simulator_before_any_recording(
        monkeypatch, tmp_path):  # fmt: skip
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[2] / "experiments"))
    import mismatch_lowfreq_probe

    with pytest.raises(SystemExit, match="--backends: kernel and/or foreign"):
        mismatch_lowfreq_probe.main(["--clean", "21000:21001", "--timing-only",
                                     "--backends", "kernel,mars", "--out", str(tmp_path)])
    assert not any(tmp_path.iterdir())  # nothing made


def test_the_regressor_comparison_refuses_bad_input_before_any_recording(monkeypatch):
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[2] / "experiments"))
    import mismatch_timing_regressors

    with pytest.raises(SystemExit, match="--bands: must be >= 2"):
        mismatch_timing_regressors.main(["--records", "kernel:340140", "--bands", "1"])
    with pytest.raises(SystemExit):  # not a benchmark seed
        mismatch_timing_regressors.main(["--records", "kernel:12"])
