"""Suite-wide pytest hooks."""

from __future__ import annotations

import time

#: Python additions timed for the header's speed index (~0.3 CPU-s).
SPEED_LOOP = 5_000_000


def machine_seconds(n: int = SPEED_LOOP) -> float:
    """CPU seconds of ``n`` Python additions: one core's speed, read beside the suite's
    time so that a slower run can be told from a slower machine (docs/robustness.md, CI
    time: the same suite took 484 s and 1052 s on two machines, both alone)."""
    start, total = time.process_time(), 0
    for i in range(n):
        total += i
    return time.process_time() - start


def pytest_report_header(config) -> str:
    return (f"machine speed: {SPEED_LOOP:.0e} Python additions in {machine_seconds():.2f} "
            "CPU-s (stop 65's machine, idle: 0.22-0.31 s; its default suite 1052 s)")
