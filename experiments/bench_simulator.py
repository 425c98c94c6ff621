"""Throughput of the batched closed-loop simulator (FRBF-PID + RLS) vs a per-design Python loop.

Usage: python experiments/bench_simulator.py [--batches 1 10 100 1000] [--record full]
       [--controller frbf_pid|pid]

Prints designs per second at each batch size for the full 1200 s / 10 Hz closed loop,
the speed of the plain per-design reference loop (the same step functions run by the
Python interpreter; timed on a few designs and a shorter run, scaled per step), the
first-call (compile or cache-load) time, and peak memory at the largest batch.  The last
line is ``speedup_at_batch_100: <ratio>``.
"""

from __future__ import annotations

import argparse
import os
import resource
import time
import tracemalloc
from dataclasses import replace

import numpy as np

from tmopt.physics.excitation import MultiSine
from tmopt.physics.simulator import SimulationConfig, simulate, simulate_reference


def population(b: int, seed: int) -> tuple[MultiSine, MultiSine]:
    """Random three-frequency designs for both TMs (amplitudes 1e-6..1e-4 m, periods
    100..1200 s, phases 0..pi), the scheme-B search space of Sec. 4.4."""
    rng = np.random.default_rng(seed)

    def one() -> MultiSine:
        return MultiSine(
            rng.uniform(1e-6, 1e-4, (b, 3)),
            2 * np.pi / rng.uniform(100, 1200, (b, 3)),
            rng.uniform(0, np.pi, (b, 3)),
        )

    return one(), one()


def time_batch(b: int, cfg: SimulationConfig, repeats: int) -> tuple[float, float]:
    """Best-of-``repeats`` (wall, process CPU) seconds of one ``simulate`` call on ``b``
    designs.  CPU time is reported too because a shared machine inflates wall time."""
    r1, r2 = population(b, seed=b)
    best = (float("inf"), float("inf"))
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        simulate(r1, r2, cfg)
        best = min(best, (time.perf_counter() - t0, time.process_time() - c0))
    return best


def reference_rate(cfg: SimulationConfig, designs: int, seconds: float) -> float:
    """Designs per second of the Python per-design loop, scaled from a shorter run."""
    short = replace(cfg, duration=seconds)
    r1, r2 = population(designs, seed=0)
    t0 = time.perf_counter()
    simulate_reference(r1, r2, short)
    per_step = (time.perf_counter() - t0) / (designs * short.n_steps)
    return 1.0 / (per_step * cfg.n_steps)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 10, 100, 1000])
    ap.add_argument("--record", choices=["full", "estimates"], default="full")
    ap.add_argument("--controller", choices=["frbf_pid", "pid"], default="frbf_pid")
    ap.add_argument("--ref-designs", type=int, default=2)
    ap.add_argument("--ref-seconds", type=float, default=60.0)
    args = ap.parse_args()
    cfg = SimulationConfig(record=args.record, controller=args.controller)
    print(f"load average: {os.getloadavg()[0]:.2f}")
    print(f"cores: {os.cpu_count()}, run: {cfg.duration:g} s at {cfg.sample_rate:g} Hz "
          f"({cfg.n_steps} steps), {cfg.controller} + RLS, record={cfg.record}")

    t0 = time.perf_counter()
    simulate(*population(1, seed=0), replace(cfg, duration=1.0))
    print(f"first call (numba compile or on-disk cache load): {time.perf_counter() - t0:.2f} s")

    rates = {}
    for b in sorted(args.batches):
        if b == max(args.batches):
            tracemalloc.start()
        sec, cpu = time_batch(b, cfg, repeats=max(1, min(10, 300 // b)))
        rates[b] = b / sec
        print(f"batch {b:5d}: {sec:8.3f} s per call, {rates[b]:9.1f} designs/s "
              f"(CPU {cpu:.3f} s, {b / cpu:.1f} designs per CPU-second)")
        if b == max(args.batches):
            _, peak = tracemalloc.get_traced_memory()
            tracemalloc.stop()
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(f"peak memory at batch {b}: {peak / 2**20:.0f} MiB allocated by numpy "
                  f"(tracemalloc), process max RSS {rss:.0f} MiB")  # fmt: skip

    ref = reference_rate(cfg, args.ref_designs, args.ref_seconds)
    print(f"reference per-design Python loop: {ref:.4f} designs/s "
          f"(timed on {args.ref_designs} designs x {args.ref_seconds:g} s, scaled per step)")
    b100 = 100 if 100 in rates else max(rates)
    print(f"speedup_at_batch_100: {rates[b100] / ref:.0f}")


if __name__ == "__main__":
    main()
