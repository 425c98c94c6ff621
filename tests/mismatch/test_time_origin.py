"""A flight recording's clock starts far from zero (LPF telemetry carries GPS seconds,
~1.1e9 s in 2016; docs/recording-format.md: "t0 arbitrary").  A diagnosis must not depend
on where the clock starts: the same findings, the same parameters, and times reported on
the recording's own clock."""

from __future__ import annotations

import math

import pytest

from tmopt.mismatch.diagnose import diagnose
from tmopt.mismatch.effects.glitch import glitch_interval_average
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.report import build_report
from tmopt.physics import MultiSine, SimulationConfig, simulate
from tmopt.physics.recording import recording_from_simulation

from .test_effects import add_force

GPS_ORIGIN = 1.2e9  # s: a GPS time of 2018, where float64 resolves ~2.4e-7 s


def _diagnosis(origin: float):
    res = simulate(MultiSine(5e-5, 2 * math.pi / 300), MultiSine(3e-5, 2 * math.pi / 500),
                   SimulationConfig(duration=600.0), seed=57)  # fmt: skip
    rec = recording_from_simulation(res, 0)
    rec.channels["time"] = rec.channels["time"] + origin
    d = data_from_recording(rec)
    t0 = float(d.time[d.n // 3]) + 0.37 * d.dt  # a glitch on x1, on the recording's clock
    add_force(d, 0, 3e-9 * glitch_interval_average(d.time, d.dt, t0, 5.0, "shapelet"))
    add_force(d, 1, 5e-14 * d.centred_time)  # a bias drift on x2
    dg = diagnose(d)
    return dg, build_report(dg), t0


@pytest.fixture(scope="module")
def both():
    return _diagnosis(0.0), _diagnosis(GPS_ORIGIN)


def test_a_gps_time_origin_changes_no_finding(both):
    (near, rep_near, _), (far, rep_far, _) = both
    keys = [ev.candidate.key for ev, _ in near.selected]
    assert {"glitch[x1]", "bias_drift[x2]"} <= set(keys), keys
    assert [ev.candidate.key for ev, _ in far.selected] == keys
    assert rep_far["unexplained"] == rep_near["unexplained"]
    assert rep_far["ambiguous"] == rep_near["ambiguous"]


def test_a_gps_time_origin_keeps_the_parameters_and_reports_times_on_its_clock(both):
    (near, rep_near, t_near), (_, rep_far, t_far) = both
    assert t_far - t_near == pytest.approx(GPS_ORIGIN, abs=1e-6)
    for a, b in zip(rep_near["effects"], rep_far["effects"], strict=True):
        assert (a["name"], a["channel"]) == (b["name"], b["channel"])
        for name, value in a["parameters"].items():
            if name == "t0_s":  # the glitch's onset moves with the clock, to float precision
                assert b["parameters"][name] - value == pytest.approx(GPS_ORIGIN, abs=1e-5)
                assert abs(value - t_near) < 0.5 * near.data.dt
            elif isinstance(value, float):
                assert b["parameters"][name] == pytest.approx(value, rel=1e-6), name
            else:
                assert b["parameters"][name] == value, name
