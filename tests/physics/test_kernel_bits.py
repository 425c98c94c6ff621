"""The simulator's kernel gives the bits of the kernel before issue 19's speed work.

The earlier kernel is read from git (``experiments/bench_speed.py``'s
``REFERENCE_KERNEL_COMMIT``) and compiled beside the current one; both run the same
prepared inputs. Skipped in a clone without that commit (e.g. a shallow one).
"""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tmopt.physics import _closed_loop as cl
from tmopt.physics.simulator import SimulationConfig, sample_times

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def kernels():
    spec = importlib.util.spec_from_file_location(
        "bench_speed", REPO / "experiments" / "bench_speed.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    reference = bench.reference_kernel_module()
    if reference is None:
        pytest.skip(f"commit {bench.REFERENCE_KERNEL_COMMIT} is not in this clone")
    return bench.run_kernel, reference.batch_kernel


@pytest.mark.parametrize("controller", ["frbf_pid", "pid"])
def test_the_kernel_gives_the_bits_of_the_kernel_before_the_speed_work(kernels, controller):
    run_kernel, reference = kernels
    cfg = replace(SimulationConfig(), duration=150.0, controller=controller)
    t = sample_times(cfg.duration, cfg.sample_rate)
    rng = np.random.default_rng(5)
    amp, period = rng.uniform(1e-6, 1e-4, (6, 2, 3)), rng.uniform(100, 1200, (6, 2, 3))
    refs = [np.sum(amp[:, k, :, None] * np.sin(2 * np.pi * t / period[:, k, :, None]),
                   axis=1) for k in range(2)]  # (6, N) multi-sines per test mass
    seeds = np.array([0, 1, 0, 7, 3, 1], dtype=np.int64)  # designs x seeds, mixed
    new = run_kernel(cl.batch_kernel, *refs, cfg, seeds)
    old = run_kernel(reference, *refs, cfg, seeds)
    assert np.isfinite(new[..., 0]).all()  # the runs identify (not all NaN or held zeros)
    assert np.array_equal(new, old, equal_nan=True)
