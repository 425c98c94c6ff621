"""experiments/m_reachable.py: bad input, the smoothing of family d, and the most information
found at an instant against the proven bound (tmopt.physics.floor.intercept_bound)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from tmopt.physics.floor import cycloid_transitions

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "m_reachable.py"


@pytest.fixture(scope="module")
def mod():
    spec = importlib.util.spec_from_file_location("m_reachable", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def study(mod):
    return mod.Study()


@pytest.mark.parametrize("argv, message", [
    (["--budget", "5"], "--budget must be"), (["--crossings", "0,2"], "--crossings must be"),
    (["--crossings", "x"], "--crossings must be"), (["--seeds", "1"], "--seeds must be"),
    (["--envelope-budget", "-1"], "--envelope-budget must be")])
def test_bad_input_is_one_line_and_exit_2(mod, capsys, argv, message):
    with pytest.raises(SystemExit) as exc:
        mod.parse(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err


def test_smoothing_keeps_rest_bounds_and_acceleration_and_limits_the_jerk(mod, study):
    fl = study.floor
    x = cycloid_transitions(fl, [fl.x_max, -fl.x_max], [0.0, 0.0], 0.9, "bang")
    s = mod.smoothed(x, 15.0, fl.sample_rate)
    fs = fl.sample_rate
    acc, acc_s = np.diff(x, 2) * fs**2, np.diff(s, 2) * fs**2
    assert s[0] == 0.0 and np.max(np.abs(s)) <= np.max(np.abs(x)) * (1 + 1e-9)
    assert np.max(np.abs(acc_s)) <= np.max(np.abs(acc)) * (1 + 1e-9)
    jerk = np.max(np.abs(np.diff(acc_s))) * fs
    assert jerk <= 2 * 0.9 * fl.force_limit / 15.0 * 1.01  # 2 a / width
    assert jerk < np.max(np.abs(np.diff(acc))) * fs / 10


def test_most_information_attains_the_proven_bound_early_and_never_exceeds_it(mod, study):
    fl = study.floor
    grid = np.array([60.0, 250.0])
    found = mod.most_information(study, grid, budget=40, seed=0)
    bound = fl.intercept_bound()
    scale = (fl.coefficient / fl.sigma_e) ** 2
    for t_end, value in zip(grid, found):
        n = int(round(t_end * fl.sample_rate))
        limit = (bound[n] - fl.prior_info) / scale
        assert value <= limit * (1 + 1e-6)
    assert found[0] == pytest.approx((bound[600] - fl.prior_info) / scale, rel=2e-3)
    assert found[1] < 0.5 * (bound[2500] - fl.prior_info) / scale  # the swing's cost
