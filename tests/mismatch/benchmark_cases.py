"""Benchmark recordings for tests that hold a rule's design cases (read draws only), made
as ``experiments/mismatch_benchmark.py --realistic`` makes them."""

from __future__ import annotations

import functools
import sys
from pathlib import Path

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@functools.cache
def recording(backend: str, seed: int):
    """Benchmark recording ``seed`` of ``backend`` (once per session)."""
    sys.path.insert(0, str(EXPERIMENTS))
    try:
        from mismatch_realistic import case_recording
    finally:
        sys.path.remove(str(EXPERIMENTS))
    return case_recording(backend, seed)[0]
