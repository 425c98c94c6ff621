"""The stiffness regressors act on the true position: the readout noise is estimated and
taken out (stop 43, docs/mismatch.md 9.19, :mod:`tmopt.mismatch.true_position`).

Two checks.  (1) Against an exact ZOH double integrator written here (a known true
position, white readout noise, an accelerometer with its own noise, a force glitch): the
estimate recovers the readout noise and holds none of the glitch.  (2) On clean
benchmark recordings already read (the eighteenth run's false alarms, kernel 170028 and
foreign 170020): with the readout as recorded, ``-k1yy n_r`` -- correlated with the
force the loop makes from ``n_r`` -- gave y1's force column GLR 16.0 and 15.4 and a
false alarm; on the true position it is consistent with noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from tmopt.mismatch.diagnose import Settings, diagnose, residual_groups
from tmopt.mismatch.fit import Column, axis_column, data_from_recording
from tmopt.mismatch.report import build_report
from tmopt.mismatch.true_position import MIN_SEGMENT, _segment_noise, readout_noise

from . import benchmark_cases

FS = 5.0
H = 1.0 / FS


def _zoh_motion(n: int, rng: np.random.Generator, glitch: float = 0.0):
    """True position (n,) of a mass under a held acceleration ``u`` (n,): slow tones, a
    random force, and optionally a one-sided exponential force glitch of amplitude
    ``glitch`` [m s^-2] at the middle (10 s damping)."""
    t = np.arange(n) * H
    u = 1e-9 * np.sin(2 * np.pi * t / 300.0) + 1e-11 * rng.standard_normal(n)
    if glitch:
        late = t >= t[n // 2]
        u = u + glitch * late * np.exp(-(t - t[n // 2]) / 10.0)
    r = np.zeros(n)
    v = 0.0
    for i in range(n - 1):  # exact for a force held over each step
        r[i + 1] = r[i] + H * v + 0.5 * H**2 * u[i]
        v += H * u[i]
    return r, u


def _kin_rows(x: np.ndarray, acc: np.ndarray) -> np.ndarray:
    """k = 0 ZOH kinematic residual, rows n = 1 .. N - 2 (fit.kinematic_target's form)."""
    return x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2] - 0.5 * H**2 * (acc[:, 1:-1] + acc[:, :-2])


def _case(glitch: float = 0.0, readout_sigma: float = 1e-9, seed: int = 4301):
    rng = np.random.default_rng(seed)
    n = 6000
    r, u = _zoh_motion(n, rng, glitch)
    noise = readout_sigma * rng.standard_normal(n)
    x = (r + noise)[None, :]
    acc = (u + 1e-13 * rng.standard_normal(n))[None, :]
    return r, noise, readout_noise(x, _kin_rows(x, acc), [(0, n)], FS)[0]


def test_the_estimate_recovers_white_readout_noise():
    _, noise, est = _case()
    err = est - noise
    assert np.var(err) < 0.05 * np.var(noise)  # 95 % of the readout noise recovered
    assert np.corrcoef(est, noise)[0, 1] > 0.97


def test_a_force_glitch_moves_both_sensors_and_is_not_taken_out():
    # 1e-10 m s^-2 over 10 s moves the mass ~5e-9 m, five times the readout noise
    r, noise, est = _case(glitch=1e-10)
    _, noise0, est0 = _case(glitch=0.0)
    assert np.allclose(noise, noise0)
    assert np.ptp(r) > 1e-6 and np.max(np.abs(est - est0)) < 1e-3 * np.std(noise)


def test_nothing_is_taken_out_where_the_accelerometer_dominates():
    """No readout noise: d is the accelerometer's integrated error alone, red; the
    plateau sits far below its low frequencies, so the estimate stays small."""
    r, _, est = _case(readout_sigma=0.0)
    rng = np.random.default_rng(1)
    acc_only = np.cumsum(np.cumsum(1e-13 * rng.standard_normal(r.size))) * H**2
    t = np.arange(r.size)
    red = acc_only - np.polyval(np.polyfit(t, acc_only, 1), t)
    assert np.std(est) < 0.1 * np.std(red)


def test_the_probes_gate_leaves_out_the_partial_gains():
    """``min_gain`` (experiments/mismatch_true_position_probe.py): 0 is the estimate;
    above 1 nothing is taken out; at 0.9 the white-noise case keeps most of it."""
    rng = np.random.default_rng(4301)
    n = 6000
    r, u = _zoh_motion(n, rng)
    x = (r + 1e-9 * rng.standard_normal(n))[None, :]
    rows = _kin_rows(x, (u + 1e-13 * rng.standard_normal(n))[None, :])[:, : n - 2]
    full = _segment_noise(rows, n, FS)
    assert np.array_equal(_segment_noise(rows, n, FS, min_gain=0.0), full)
    assert not _segment_noise(rows, n, FS, min_gain=1.01).any()
    gated = _segment_noise(rows, n, FS, min_gain=0.9)
    assert 0.5 * np.var(full) < np.var(gated) <= np.var(full) * 1.001


def test_short_segments_get_no_estimate():
    x = np.ones((2, MIN_SEGMENT - 1))
    out = readout_noise(x, np.zeros((2, MIN_SEGMENT - 3)), [(0, MIN_SEGMENT - 1)], FS)
    assert out.shape == x.shape and not out.any()


def _y1_force_glr(dg) -> float:
    g = residual_groups(dg.data, dg.before)["equation"]
    return g.glr([Column("f_y1", axis_column(dg.basis, 2, dg.data.force[2]))])


@pytest.mark.parametrize("backend,seed", [pytest.param("kernel", 170028, marks=pytest.mark.slow),
                                          ("foreign", 170020)])  # fmt: skip
def test_a_clean_recording_raises_no_force_term_on_the_true_position(backend, seed):
    data = data_from_recording(benchmark_cases.recording(backend, seed))
    dg = diagnose(data)
    assert _y1_force_glr(dg) < 10.83  # chi^2(1) at 0.001
    assert build_report(dg)["mismatch_detected"] is False


@pytest.mark.slow  # the failure, documented (15 s); the rule's own tests above are in the suite
def test_on_the_readout_as_recorded_the_loop_force_is_named():
    """The failure the rule fixes (kernel 170028, true_position off)."""
    dg = diagnose(data_from_recording(benchmark_cases.recording("kernel", 170028)),
                  Settings(true_position=False))  # fmt: skip
    assert _y1_force_glr(dg) > 14.0
    assert build_report(dg)["mismatch_detected"] is True
