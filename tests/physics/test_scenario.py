"""Scenarios: excitation specs, and the one sample-rate rule on every route (the stiffness
problem, the recording generator, ``python -m tmopt.simulate``)."""

import ast
import math
from pathlib import Path

import numpy as np
import pytest

import tmopt.physics
from tmopt.physics.control import closed_loop_poles
from tmopt.physics.geometry import Geometry
from tmopt.physics.scenario import Settings, config_at_rate, excitation, simulation_config
from tmopt.physics.simulator import SimulationConfig
from tmopt.problems.stiffness import StiffnessProblem


def test_excitation_specs():
    r1, r2, info = excitation("paper", 600.0, 10.0)
    t = np.arange(6000) / 10.0
    np.testing.assert_allclose(r1, 5e-5 * np.sin(2 * np.pi * t / 300), rtol=0, atol=1e-18)
    np.testing.assert_allclose(r2, 3e-5 * np.sin(2 * np.pi * t / 500), rtol=0, atol=1e-18)
    s1, s2, info = excitation("steps:3e-5,100;1e-5,100,50", 400.0, 10.0)
    # +A from the start, switching every 100 s: -A before 200 s, +A before 300 s
    assert s1[0] == 0 and s1[999] == pytest.approx(3e-5) and s1[1999] == pytest.approx(-3e-5)
    assert s1[2999] == pytest.approx(3e-5)
    assert info["tm2"]["ramp_s"] == 50
    assert np.max(np.abs(np.diff(s1, 2))) * 100 <= 0.5e-7 * 1.01  # 0.5 F_max (Eq. 20)


@pytest.mark.parametrize("spec,match", [
    ("sweep:1", "kind must be one of"),
    ("multisine:5e-5@300", "both test masses"),
    ("multisine:5e-5@0.1;1e-5@300", "Nyquist"),
    ("multisine:1e-3@3000;1e-5@300", "0.0004 m"),
    ("multisine:1e-4@20;1e-5@300", "F_max"),
    ("chirp:1e-5,0.1,6;1e-5,0.1,0.2", "chirp needs"),
    ("chirp:1e-5,0.1;1e-5,0.1,0.2", "needs 3 numbers"),
    ("steps:1e-5,10,20;1e-5,100", "ramp <= hold"),
    ("multisine:abc@3;1e-5@300", "could not convert|abc"),
])  # fmt: skip
def test_bad_excitations_name_the_spec(spec, match):
    with pytest.raises(ValueError, match=match):
        excitation(spec, 600.0, 10.0)


@pytest.mark.parametrize("fs", [0.01, 0.1, 1.0, 4.0, 10.0, 20.0, 100.0, 1000.0])
def test_rescaled_controller_is_stable_at_every_rate(fs):
    cfg = simulation_config(Settings(sample_rate=fs, duration=64 / fs), Geometry())
    for gains in (cfg.control.base_gains, cfg.control.y_gains):
        assert np.abs(closed_loop_poles(gains, 1 / fs)).max() < 1
    # the continuous gains P = Kp, I = Ki / dt, D = Kd dt are those of the 10 Hz design
    kp, ki, kd = cfg.control.base_gains
    assert (kp, ki * fs, kd / fs) == pytest.approx((0.5, 0.1, 1.0))


@pytest.mark.parametrize("fs", [5.0, 20.0, 40.0])
def test_the_stiffness_problem_keeps_the_10hz_physics_at_other_rates(fs):
    # P = Kp, I = Ki/dt, D = Kd dt and the noise ASDs sigma / sqrt(fs/2) are those of the
    # paper's 10 Hz design (Sec. 4.2, Table 1) whatever the sample rate
    cfg = StiffnessProblem(sample_rate=fs, duration=120.0).config
    paper = SimulationConfig()
    for gains, design in ((cfg.control.base_gains, paper.control.base_gains),
                          (cfg.control.y_gains, paper.control.y_gains)):  # fmt: skip
        kp, ki, kd = gains
        assert (kp, ki * fs, kd / fs) == pytest.approx((design[0], design[1] * 10,
                                                        design[2] / 10), rel=1e-12)  # fmt: skip
    for name in ("sigma_m1", "sigma_m2", "sigma_acc", "sigma_ele", "fb_sigma"):
        asd, asd_paper = getattr(cfg, name) / math.sqrt(fs / 2), getattr(paper, name) / math.sqrt(5)
        assert asd == pytest.approx(asd_paper, rel=1e-12), name


@pytest.mark.parametrize("fs", [4.0, 10.0, 20.0])
def test_problem_generator_and_simulate_build_one_physics(fs):
    problem = StiffnessProblem(sample_rate=fs, duration=300.0).config
    generator = simulation_config(Settings(sample_rate=fs, duration=300.0), Geometry())
    for field in ("sample_rate", "duration", "controller", "control", "sigma_m1", "sigma_m2",
                  "sigma_acc", "sigma_ele", "fb_sigma", "fb_bias", "stiffness_1", "stiffness_2",
                  "bias_1", "bias_2", "geometry", "f_max"):  # fmt: skip
        assert getattr(problem, field) == getattr(generator, field), field


def test_the_rule_at_10hz_is_the_default_configuration():
    # at the paper's rate the rule changes no bit: the stiffness problem's archives stay
    assert config_at_rate(10.0, duration=600.0, record="estimates") == SimulationConfig(
        duration=600.0, record="estimates")
    assert config_at_rate(20.0, 0.0).sigma_m2 == 0.0


@pytest.mark.parametrize("kwargs, match", [
    ({"sample_rate": 0.0}, r"sample_rate must be finite and in \(0, inf\) Hz"),
    ({"sample_rate": float("nan")}, "sample_rate"),
    ({"noise_scale": -1.0}, r"noise_scale must be finite and in \[0, inf\)"),
])  # fmt: skip
def test_the_rule_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        config_at_rate(**kwargs)


def test_physics_imports_nothing_of_ours_outside_physics():
    # the test-mass world knows nothing of optimisation or of the mismatch tool; it may
    # use tmopt.files, the ground floor that imports nothing (tests/test_layers.py)
    for path in Path(tmopt.physics.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            for name in names:
                assert not name.startswith("tmopt") or name.startswith(
                    ("tmopt.physics", "tmopt.files")), (path.name, name)
