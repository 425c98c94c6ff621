"""A benchmark that misbehaves on purpose, to test and demonstrate fault handling.

Wraps a suite problem and, depending on the first decision variable (scaled to [0, 1]),
raises, returns NaN or hangs for chosen designs, and can delay every batch so that a
run is slow enough to be interrupted. Real expensive problems fail in these ways
(a simulator that crashes, diverges to NaN, or never returns); the evaluator must mark
exactly those designs as failed and keep going.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from tmopt.problems.base import ExpensiveProblem
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark


class FaultyProblem(ExpensiveProblem):
    """A suite problem with injected faults.

    Args:
        base: Suite problem to wrap (e.g. ``"mw1"``).
        n_var: Its number of variables (None: the published default).
        raise_band: ``[lo, hi]`` of the scaled first variable where evaluation raises.
        nan_band: ``[lo, hi]`` where the objectives come back NaN.
        hang_band: ``[lo, hi]`` where evaluation sleeps ``hang_seconds`` first.
        hang_seconds: How long a "hung" evaluation sleeps.
        batch_delay: Seconds every call sleeps (makes runs slow enough to kill).
        name: Problem name.
    """

    def __init__(self, *, base: str = "mw1", n_var: int | None = None,
                 raise_band: Sequence[float] | None = None,
                 nan_band: Sequence[float] | None = None,
                 hang_band: Sequence[float] | None = None,
                 hang_seconds: float = 3600.0, batch_delay: float = 0.0,
                 name: str = "faulty") -> None:
        if str(base).lower() not in SUITE_PROBLEMS:  # named as this problem's parameter
            raise ValueError(f"problem {name}: base={base!r} is not a suite problem with an "
                             f"offline front; choose one of: {', '.join(SUITE_PROBLEMS)}")
        self.base = PymooBenchmark(base, n_var=n_var)
        self.bands = {kind: _band(name, f"{kind}_band", band) for kind, band in
                      (("raise", raise_band), ("nan", nan_band), ("hang", hang_band))}
        if not (np.isfinite(hang_seconds) and hang_seconds >= 0):
            raise ValueError(f"problem {name}: hang_seconds must be >= 0, got {hang_seconds!r}")
        if not (np.isfinite(batch_delay) and batch_delay >= 0):
            raise ValueError(f"problem {name}: batch_delay must be >= 0, got {batch_delay!r}")
        self.hang_seconds, self.batch_delay = float(hang_seconds), float(batch_delay)
        b = self.base
        super().__init__(n_var=b.n_var, n_obj=b.n_obj, n_ieq_constr=b.n_ieq_constr, xl=b.xl,
                         xu=b.xu, name=name, constraint_groups=b.constraint_groups)

    def _in(self, kind: str, X: np.ndarray) -> np.ndarray:
        band = self.bands[kind]
        if band is None:
            return np.zeros(len(X), dtype=bool)
        u = (X[:, 0] - self.xl[0]) / (self.xu[0] - self.xl[0])
        return (u >= band[0]) & (u <= band[1])

    def _evaluate(self, X, out, *args, **kwargs):
        time.sleep(self.batch_delay)
        if self._in("raise", X).any():
            raise RuntimeError("injected fault: the simulator crashed")
        if self._in("hang", X).any():
            time.sleep(self.hang_seconds)
        res = self.base.evaluate(X, return_as_dictionary=True)
        F = np.array(res["F"], dtype=float)
        F[self._in("nan", X)] = np.nan
        out["F"] = F
        if self.n_ieq_constr:
            out["G"] = res["G"]

    def _calc_pareto_front(self, *args, **kwargs):
        return self.base.pareto_front(*args, **kwargs)


def _band(problem: str, label: str, band) -> tuple[float, float] | None:
    if band is None:
        return None
    lo, hi = (float(v) for v in band)
    if not (0.0 <= lo <= hi <= 1.0):
        raise ValueError(f"problem {problem}: {label} must be [lo, hi] with 0 <= lo <= hi <= 1, "
                         f"got {list(band)!r}")
    return lo, hi
