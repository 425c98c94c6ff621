"""Scenarios: excitation specs, and the one sample-rate rule on every route (the stiffness
problem, the recording generator, ``python -m tmopt.simulate``)."""

import ast
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import tmopt.physics
from tmopt import simulate as simulate_command
from tmopt.mismatch.generate import SPACECRAFT_ACCELERATION, generate_recording
from tmopt.physics.control import ControllerSettings, closed_loop_poles, rate_scaled_gains
from tmopt.physics.geometry import Geometry
from tmopt.physics.scenario import (
    MIN_SAMPLE_RATE,
    Y_AXES,
    Settings,
    config_at_rate,
    excitation,
    simulation_config,
)
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


@pytest.mark.parametrize("y_axes", sorted(Y_AXES))
@pytest.mark.parametrize("fs", [MIN_SAMPLE_RATE, 4.0, 10.0, 20.0, 100.0, 1000.0])
def test_rescaled_controller_is_stable_at_every_rate(fs, y_axes):
    cfg = simulation_config(Settings(sample_rate=fs, duration=64 / fs, y_axes=y_axes),
                            Geometry())  # fmt: skip
    ctl = cfg.control
    assert np.abs(closed_loop_poles(ctl.base_gains, 1 / fs)).max() < 1
    assert np.abs(closed_loop_poles(ctl.y_gains, 1 / fs, ctl.y_derivative_filter)).max() < 1
    # the continuous gains P = Kp, I = Ki / dt, D = Kd dt are those of the 10 Hz design
    kp, ki, kd = cfg.control.base_gains
    assert (kp, ki * fs, kd / fs) == pytest.approx((0.5, 0.1, 1.0))


@pytest.mark.parametrize("fs", [0.1, 0.5, 0.9])
def test_the_rule_rejects_unstable_rates(fs):
    # the 10 Hz design's ~0.7 rad/s sensitive loop, rescaled, is unstable this slowly (the
    # sample delay u_n -> x_{n+1}; an earlier pole computation without it said "stable")
    gains = rate_scaled_gains(ControllerSettings().base_gains, fs)
    assert np.abs(closed_loop_poles(gains, 1 / fs)).max() > 1
    # ... so every route refuses the rate with one line naming it and the allowed range
    for make in (lambda: config_at_rate(fs), lambda: Settings(sample_rate=fs, duration=1e4),
                 lambda: StiffnessProblem(sample_rate=fs, duration=1e4)):  # fmt: skip
        with pytest.raises(ValueError, match=r"sample_rate must be finite and in \[1, inf\) Hz"):
            make()


@pytest.mark.parametrize("fs", [10.0, 20.0])
def test_noise_scale_scales_the_spacecraft_acceleration_on_every_route(fs):
    # f_B noise follows the rule like Table 1's: noise_scale * sqrt(fs / 10 Hz) at 10 Hz's
    want = 1e-10 * 3.0 * math.sqrt(fs / 10.0)
    assert config_at_rate(fs, 3.0, y_axes="round1").fb_sigma == pytest.approx(want, rel=1e-12)
    st = Settings(sample_rate=fs, duration=300.0, noise_scale=3.0, y_axes="round1")
    assert simulate_command.config(st).fb_sigma == pytest.approx(want, rel=1e-12)
    # the generator's recordings carry the round-one f_B whatever the y axes
    _, truth = generate_recording((), 0, sample_rate=fs, duration=300.0, noise_scale=3.0)
    assert truth["nominal"]["fb_sigma"] == pytest.approx(want, rel=1e-12)
    assert truth["nominal"]["fb_bias_s"] == list(SPACECRAFT_ACCELERATION["fb_bias"])
    # ... and otherwise the scenario's run (Table 1 noise, rescaled gains, drag-free y loop)
    cfg = simulate_command.config(replace(st, y_axes="drag_free"))
    for key in ("sigma_m1", "sigma_m2", "sigma_acc", "sigma_ele"):
        assert truth["nominal"][key] == getattr(cfg, key), key
    assert truth["nominal"]["base_gains"] == list(cfg.control.base_gains)
    assert truth["nominal"]["y_gains"] == list(cfg.control.y_gains)


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


PHYSICS_OPTIONS = [{}, {"ramp_in": 30.0, "rls_columns": "all", "y_axes": "round1",
                       "jacobian": "online"}]  # fmt: skip
ONE_PHYSICS = ("sample_rate", "duration", "controller", "control", "sigma_m1", "sigma_m2",
               "sigma_acc", "sigma_ele", "fb_sigma", "fb_bias", "stiffness_1", "stiffness_2",
               "bias_1", "bias_2", "geometry", "f_max", "ramp_in", "rls_columns")  # fmt: skip


@pytest.mark.parametrize("options", PHYSICS_OPTIONS)
@pytest.mark.parametrize("fs", [4.0, 10.0, 20.0])
def test_problem_generator_and_simulate_build_one_physics(fs, options):
    # the physics options of issue 17 reach the simulator by the one route, at any rate
    problem = StiffnessProblem(sample_rate=fs, duration=300.0, **options).config
    settings = Settings(sample_rate=fs, duration=300.0, **options)
    command = simulate_command.config(settings)
    for field in ONE_PHYSICS:
        assert getattr(problem, field) == getattr(command, field), field
    # the generator: the same run plus its spacecraft acceleration, by the same rule
    generator = simulation_config(settings, Geometry(), **SPACECRAFT_ACCELERATION)
    jitter = config_at_rate(fs, **SPACECRAFT_ACCELERATION)
    for field in ONE_PHYSICS:
        want = getattr(jitter if field.startswith("fb_") else command, field)
        assert getattr(generator, field) == want, field


def test_the_rule_at_10hz_is_the_default_configuration():
    # at the paper's rate the rule changes no bit: the stiffness problem's archives stay
    assert config_at_rate(10.0, duration=600.0, record="estimates") == SimulationConfig(
        duration=600.0, record="estimates")
    assert config_at_rate(20.0, 0.0).sigma_m2 == 0.0


@pytest.mark.parametrize("kwargs, match", [
    ({"sample_rate": 0.0}, r"sample_rate must be finite and in \[1, inf\) Hz"),
    ({"y_axes": "lisa"}, r"y_axes must be one of \['drag_free', 'round1'\]"),
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
