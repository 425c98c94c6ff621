"""Problem evaluations under a time limit, in a separate worker process.

A slow or hung evaluation cannot be interrupted inside the optimiser's own process (a
compiled simulator holds the interpreter lock; forking a process that runs numba or torch
thread pools is unsafe). So, when a time limit is set, evaluations run in one persistent
worker started with the ``spawn`` method: the problem is sent to it once, each batch is a
message, and a batch that overruns its limit gets the worker killed and a fresh one
started. The cost is one process start (imports) per run and per timeout.
"""

from __future__ import annotations

import multiprocessing as mp
import traceback

import numpy as np


class EvaluationTimeout(RuntimeError):
    """A batch did not finish within its time limit; the worker was killed."""


def _serve(problem, conn) -> None:
    """Worker loop: say ready, then evaluate every batch received until told to stop."""
    conn.send(("ready",))
    while True:
        message = conn.recv()
        if message is None:
            return
        X, context = message
        try:
            out = problem.evaluate(X, return_as_dictionary=True, **context)
            conn.send(("ok", {k: np.asarray(v) for k, v in out.items()}))
        except Exception as exc:  # noqa: BLE001 - reported back to the parent
            conn.send(("raised", f"{type(exc).__name__}: {exc}", traceback.format_exc()))


class IsolatedProblem:
    """Evaluates ``problem`` in a worker process with a per-design time limit.

    Args:
        problem: A picklable problem (pymoo ``Problem``).
        seconds_per_design: Time allowed per design; a batch of n designs gets n times that.
    """

    def __init__(self, problem, seconds_per_design: float) -> None:
        if not (np.isfinite(seconds_per_design) and seconds_per_design > 0):
            raise ValueError(f"eval_time_limit must be a finite number of seconds > 0, "
                             f"got {seconds_per_design!r}")
        self.problem = problem
        self.limit = float(seconds_per_design)
        self._ctx = mp.get_context("spawn")
        self._proc = None
        self._conn = None

    def _start(self, startup_timeout: float) -> None:
        """Start a worker and wait until it has imported everything (not timed as work)."""
        parent, child = self._ctx.Pipe()
        self._proc = self._ctx.Process(target=_serve, args=(self.problem, child), daemon=True)
        self._proc.start()
        child.close()
        self._conn = parent
        if not parent.poll(startup_timeout) or parent.recv() != ("ready",):
            self.kill()
            raise RuntimeError(f"the evaluation worker did not start within {startup_timeout} s")

    def evaluate(self, X: np.ndarray, startup_timeout: float = 300.0, **context) -> dict:
        """``problem.evaluate(X, return_as_dictionary=True, **context)`` or raise on
        timeout/error (``context``: the evaluator's ``rows`` and ``run_seed``)."""
        if self._proc is None or not self._proc.is_alive():
            self._start(startup_timeout)
        self._conn.send((np.asarray(X, dtype=float), context))
        if not self._conn.poll(self.limit * len(X)):
            self.kill()
            raise EvaluationTimeout(f"evaluation exceeded the time limit of "
                                    f"{self.limit:g} s per design")
        try:
            reply = self._conn.recv()
        except EOFError:
            self.kill()
            raise RuntimeError("the evaluation worker died (killed or crashed)") from None
        if reply[0] == "raised":
            raise RuntimeError(reply[1])
        return reply[1]

    def kill(self) -> None:
        if self._proc is not None and self._proc.is_alive():
            self._proc.kill()
            self._proc.join(5)
        self._proc = None
        self._conn = None

    def close(self) -> None:
        """Stop the worker (politely if it is idle)."""
        if self._proc is not None and self._proc.is_alive():
            try:
                self._conn.send(None)
                self._proc.join(5)
            except (OSError, BrokenPipeError):
                pass
        self.kill()
