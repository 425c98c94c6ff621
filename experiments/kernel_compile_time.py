"""The closed-loop kernel's first call (its numba compile) in a fresh process.

Run with an empty cache so the compile is measured, e.g.
``NUMBA_CACHE_DIR=$(mktemp -d) python experiments/kernel_compile_time.py``
(docs/robustness.md, "CI time").  Prints wall seconds of the import, the first call and a
second call; read CPU seconds with ``time`` on a loaded machine.
"""

from __future__ import annotations

import math
import time


def main() -> None:
    t0 = time.perf_counter()
    from tmopt.physics import _closed_loop as cl
    from tmopt.physics.excitation import MultiSine
    from tmopt.physics.simulator import _KERNEL_ARGS, SimulationConfig, prepare

    t1 = time.perf_counter()
    tone = MultiSine(1e-6, 2 * math.pi * 0.01)
    io = prepare(tone, tone, SimulationConfig(), 0, None, None)
    t2 = time.perf_counter()
    cl.batch_kernel(*(io[k] for k in _KERNEL_ARGS))
    t3 = time.perf_counter()
    cl.batch_kernel(*(io[k] for k in _KERNEL_ARGS))
    t4 = time.perf_counter()
    print(f"import {t1 - t0:.1f} s, first call {t3 - t2:.1f} s, second {t4 - t3:.2f} s")


if __name__ == "__main__":
    main()
