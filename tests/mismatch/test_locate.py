"""Locate: no false alarms on white noise, and bands / windows / axes where excess is put."""

from __future__ import annotations

import math

import numpy as np

from tmopt.mismatch.fit import null_basis
from tmopt.mismatch.locate import (
    axis_directions,
    excess_axes,
    frequency_bands,
    locate,
    time_windows,
    tone_transfer,
)
from tmopt.physics.geometry import Geometry

FS = 10.0
M = 6000
TIME = np.arange(M) / FS


def test_white_noise_rarely_raises_an_alarm():
    # alpha = 0.01 per record: 50 records -> P(>= 4 alarms) = 0.0016 if calibrated
    alarms = 0
    for seed in range(50):
        w = np.random.default_rng(seed).standard_normal((2, M))
        alarms += locate(w, TIME, FS, 0.01).any
    assert alarms <= 3


def test_a_line_is_located_in_frequency():
    w = np.random.default_rng(1).standard_normal((2, M))
    w[0] += 0.3 * np.sin(2 * math.pi * 0.7 * TIME)
    bands, p, *_ = frequency_bands(w, FS, 0.01)
    assert p < 1e-6
    assert any(lo <= 0.7 <= hi for lo, hi in bands)
    assert all(hi - lo < 0.05 for lo, hi in bands)


def test_a_transient_is_located_in_time():
    w = np.random.default_rng(2).standard_normal((2, M))
    w[:, 3000:3020] += 3.0
    wins, p = time_windows(w, TIME, FS, 0.01)
    assert p < 1e-6
    assert any(t0 <= 300.0 and 301.9 <= t1 for t0, t1 in wins)
    assert all(t1 - t0 <= 20.0 for t0, t1 in wins)


def test_excess_direction_names_the_axis():
    basis = null_basis(Geometry())
    dirs = axis_directions(basis, np.eye(2))
    w = np.random.default_rng(3).standard_normal((2, M))
    line = 0.5 * np.sin(2 * math.pi * 1.3 * TIME)
    w += np.outer(dirs[:, 1], line)  # a disturbance on x2 only
    assert excess_axes(w, dirs, FS, [[1.25, 1.35]])[0] == "x2"


def test_tone_transfer_flat_for_stiffness_and_quadrature_for_delay():
    t = TIME
    x = 1e-5 * (np.sin(2 * math.pi * 0.01 * t) + np.sin(2 * math.pi * 0.05 * t))
    stiff = tone_transfer(2e-9 * x, x, FS, [0.01, 0.05])
    assert all(abs(r["magnitude"] - 2e-9) < 1e-11 and abs(r["phase_deg"]) < 1 for r in stiff)
    # delay: r = -tau x'' ' ~ i w^3 tau x (sign aside), magnitude ratio (0.05/0.01)^3 = 125
    xdot3 = np.gradient(np.gradient(np.gradient(x, t), t), t)
    dl = tone_transfer(1e-2 * xdot3, x, FS, [0.01, 0.05])
    assert all(abs(abs(r["phase_deg"]) - 90) < 2 for r in dl)
    assert abs(dl[1]["magnitude"] / dl[0]["magnitude"] - 125) < 3
