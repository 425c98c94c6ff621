"""The lock-step kernel (``run_group``: runs advanced together, the run as the SIMD lane)
gives every run the bits that ``run_design`` gives it alone.

The reference is ``run_design`` compiled on its own, one run after the other (the path of
the perturbed model and of ``simulate_reference``); both see the same prepared inputs.
Every kernel output is compared: estimates, summary, status, and in ``record="full"`` all
channels and gains.  Runs that diverge at different samples share a group with runs that
do not, groups are padded (runs not a multiple of the lanes) or hold a single run.
"""

from __future__ import annotations

from dataclasses import replace

import numba as nb
import numpy as np
import pytest

from tmopt.physics import _closed_loop as cl
from tmopt.physics import simulator as S
from tmopt.physics.control import ControllerSettings
from tmopt.physics.simulator import SimulationConfig, sample_times

OUTPUTS = ("out_th", "summary", "status", "out_ch", "out_gain")


@nb.njit(cache=True)
def _one_by_one(ref1, ref2, refy, noise, noise_of, par, c0, b0, out_ch, out_th, out_gain,
                summary, status, record, pp, ps):
    for i in range(ref1.shape[0]):
        cl.run_design(i, ref1, ref2, refy, noise[noise_of[i]], par, c0, b0, out_ch, out_th,
                      out_gain, summary, status, record, pp, ps)


def _references(b: int, t: np.ndarray, seed: int, big: int = 0) -> list[np.ndarray]:
    """(B, N) multi-sines per test mass; the first ``big`` designs leave the bound."""
    rng = np.random.default_rng(seed)
    amp, period = rng.uniform(1e-6, 1e-4, (b, 2, 3)), rng.uniform(100, 1200, (b, 2, 3))
    amp[:big] *= np.linspace(2, 6, big)[:, None, None]  # leave 2e-4 m at different samples
    return [np.sum(amp[:, k, :, None] * np.sin(2 * np.pi * t / period[:, k, :, None]),
                   axis=1) for k in range(2)]


def _both(cfg: SimulationConfig, refs, seeds, lanes: int | None = None, ref_y=None):
    outs = []
    for kernel in ("lockstep", "scalar"):
        io = S.prepare(*refs, cfg, seeds, ref_y=ref_y)
        if lanes is not None:
            io["lanes"] = lanes
        args = [io[k] for k in S._KERNEL_ARGS]
        if kernel == "lockstep":
            cl.batch_kernel(*args)
        else:
            _one_by_one(*args[:-1])
        # the channels exist only in record="full" (else unwritten (16, 1, 1) placeholders)
        outs.append({k: io[k] for k in OUTPUTS if io["record"] or k in OUTPUTS[:3]})
    return outs


def _assert_same(new: dict, old: dict) -> None:
    assert new.keys() == old.keys()
    for key in new:
        assert np.array_equal(new[key], old[key], equal_nan=True), key


@pytest.mark.parametrize("controller, jacobian, y_filter, record", [
    ("frbf_pid", "plus", 0.5, "estimates"),
    ("frbf_pid", "online", 0.0, "full"),
    ("pid", "plus", 0.5, "full"),
])
def test_lockstep_runs_have_the_bits_of_runs_alone(controller, jacobian, y_filter, record):
    cfg = SimulationConfig(duration=120.0, controller=controller, record=record,
                           divergence_bound=2e-4,
                           control=ControllerSettings(jacobian=jacobian,
                                                 y_derivative_filter=y_filter))
    t = sample_times(cfg.duration, cfg.sample_rate)
    b = 21  # with lanes=16: a group of 16 lanes, then 5 runs in 8 lanes (3 padded)
    refs = _references(b, t, seed=3, big=4)
    seeds = np.array([0, 1, 2, 5, 1] * 4 + [7], dtype=np.int64)
    new, old = _both(cfg, refs, seeds, lanes=16)
    status = old["status"][:, 0]
    assert (status == cl.OK).sum() >= 10  # most runs identify ...
    assert (status != cl.OK).sum() >= 2  # ... some diverge, at different samples
    assert len(set(old["status"][status != cl.OK, 1])) >= 2
    assert np.isfinite(old["out_th"][status == cl.OK][..., 0]).all()
    _assert_same(new, old)


@pytest.mark.parametrize("lanes", [8, 24])
def test_group_size_changes_no_bit(lanes):
    cfg = replace(SimulationConfig(), duration=60.0, record="estimates", divergence_bound=2e-4)
    t = sample_times(cfg.duration, cfg.sample_rate)
    refs = _references(9, t, seed=8, big=2)
    seeds = np.arange(9, dtype=np.int64) % 4
    new, old = _both(cfg, refs, seeds, lanes=lanes)
    _assert_same(new, old)


def test_y_set_points_move_the_lanes_as_they_move_a_run_alone():
    """Issue 22's y set points (``ref_y``) reach every lane of a group."""
    cfg = replace(SimulationConfig(), duration=60.0, record="full")
    t = sample_times(cfg.duration, cfg.sample_rate)
    refs = _references(10, t, seed=4)
    ref_y = [0.5 * r for r in _references(10, t, seed=5)]
    seeds = np.arange(10, dtype=np.int64) % 3
    new, old = _both(cfg, refs, seeds, lanes=8, ref_y=ref_y)
    _assert_same(new, old)
    still, _ = _both(cfg, refs, seeds, lanes=8)
    assert not np.array_equal(new["out_ch"][4:8], still["out_ch"][4:8])  # y really moved


def test_runs_whose_estimate_turns_non_finite_hold_the_sample_before():
    # P0 near the largest double: P psi overflows and the estimate turns NaN at sample 1
    cfg = replace(SimulationConfig(), duration=10.0, record="full", rls_p0=1e300)
    t = sample_times(cfg.duration, cfg.sample_rate)
    new, old = _both(cfg, _references(3, t, seed=1), np.array([0, 1, 2], dtype=np.int64),
                     lanes=8)
    assert (old["status"][:, 0] == cl.BAD_ESTIMATE).all()
    _assert_same(new, old)


def test_group_lanes_layout():
    assert cl.group_lanes(100, 1) == 104  # one group, 4 padding lanes
    assert cl.group_lanes(100, 2) == 56  # a group per thread
    assert cl.group_lanes(1, 2) == 8
    assert cl.group_lanes(0, 2) == 8  # an empty batch: no group runs
    assert cl.group_lanes(1000, 2) == 128  # capped: 8 groups
    for n, threads in [(0, 1), (1, 1), (7, 16), (100, 16), (333, 2), (3200, 4)]:
        lanes = cl.group_lanes(n, threads)
        assert lanes % cl.LANE_ALIGN == 0 and cl.LANE_ALIGN <= lanes <= cl.GROUP_MAX
