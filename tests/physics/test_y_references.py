"""Non-sensitive-axis set points: the y loops track them, nothing changes without them,
and the four-group multisine spec obeys Eq. 20 with the y gap."""

from __future__ import annotations

import numpy as np
import pytest

from tmopt.physics.geometry import Geometry
from tmopt.physics.scenario import Y_GAP, Settings, excitation, excitation_axes, simulation_config
from tmopt.physics.simulator import simulate, simulate_reference


@pytest.fixture(scope="module")
def runs():
    refs, _ = excitation_axes("multisine:5e-5@300;3e-5@500;5e-5@400;2e-5@250", 600.0, 10.0)
    cfg = simulation_config(Settings(duration=600.0), Geometry())
    plain = simulate(refs[0][None], refs[1][None], cfg, 7)
    zeros = simulate(refs[0][None], refs[1][None], cfg, 7,
                     ref_y=(np.zeros((1, 6000)), np.zeros((1, 6000))))  # fmt: skip
    moved = simulate(refs[0][None], refs[1][None], cfg, 7, ref_y=(refs[2][None], refs[3][None]))
    return refs, plain, zeros, moved


def test_zero_set_points_are_bit_identical(runs):
    _, plain, zeros, _ = runs
    np.testing.assert_array_equal(plain.channels, zeros.channels)
    np.testing.assert_array_equal(plain.theta_hat, zeros.theta_hat)
    assert plain.ref_y is None and zeros.ref_y is not None


def test_y_loops_track_their_set_points(runs):
    refs, _, _, moved = runs
    ramp = moved.ref_y[0]  # the start ramp applies to every reference
    for k, name in ((0, "y1_true"), (1, "y2_true")):
        y = getattr(moved, name)[0]
        err = np.abs(y - ramp[k])[1500:].max()  # after the ramp and the loop's transient
        assert err < 0.01 * np.abs(refs[2 + k]).max(), (name, err)
    assert moved.max_abs_position[0, 2] > 4e-5


def test_compiled_and_interpreted_paths_agree_with_y_set_points():
    refs, _ = excitation_axes("multisine:5e-5@300;3e-5@500;1e-6@40;", 20.0, 10.0)
    cfg = simulation_config(Settings(duration=20.0), Geometry())
    args = (refs[0][None], refs[1][None], cfg, 3)
    ry = (refs[2][None], refs[3][None])
    a, b = simulate(*args, ref_y=ry), simulate_reference(*args, ref_y=ry)
    np.testing.assert_allclose(a.channels, b.channels, rtol=1e-12, atol=1e-22)


def test_four_group_spec_and_its_limits():
    refs, info = excitation_axes("multisine:5e-5@300;;1e-4@600,2e-5@100@1;", 100.0, 10.0)
    assert refs.shape == (4, 1000) and not np.any(refs[1]) and not np.any(refs[3])
    assert [c["period_s"] for c in info["tm1_y"]] == [600.0, 100.0]
    too_far = 0.1 * Y_GAP * 0.6  # |y| reaches 2A = 1.2 alpha2 D_y
    with pytest.raises(ValueError, match="TM1 y reference reaches"):
        excitation_axes(f"multisine:5e-5@300;3e-5@500;{too_far}@1000@1.5708;", 1200.0, 10.0)
    with pytest.raises(ValueError, match="takes x1 and x2 only"):
        excitation("multisine:5e-5@300;3e-5@500;1e-5@300;", 100.0, 10.0)
    with pytest.raises(ValueError, match="both test masses"):
        excitation_axes("multisine:5e-5@300;3e-5@500;1e-5@300", 100.0, 10.0)
