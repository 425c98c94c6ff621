"""Real evaluations: budget counting, archiving, failure isolation and resume by replay.

Every real evaluation of a run goes through one :class:`Evaluator`. It

* counts evaluations against the budget and refuses to exceed it;
* isolates failures: if a vectorised evaluation raises (or overruns its time limit), the
  batch is re-evaluated one design at a time so only the offending designs fail;
  non-finite objectives or constraints also mark a design as failed. A failed design is
  recorded with its reason and handed to the algorithm as infeasible (see
  :func:`sanitise`), and the run goes on;
* appends each batch to the on-disk archive before returning it, so a killed run loses
  nothing already evaluated;
* resumes by replay: given the archive of an interrupted run, it answers the first
  evaluations from the archive instead of the problem. Because algorithms are
  deterministic under a seed, they ask for exactly the archived designs again, and the
  resumed run ends with the same result as an uninterrupted one. A design that differs
  from the archived one means the archive belongs to another experiment: an error.
  Rows that failed their checksum (``damaged``) are not trusted: their batch is evaluated
  again for real and the replay goes on behind it while the algorithm still asks for the
  archived designs (docs/decisions.md, "Archive checksums").
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from tmopt.evaluation.archive import ArchiveData, ArchiveError, EvaluationArchive
from tmopt.evaluation.isolation import EvaluationTimeout, IsolatedProblem
from tmopt.problems.base import ExpensiveProblem

log = logging.getLogger(__name__)

# Added to the worst finite value seen so far, so a failed design ranks below all others.
FAILED_CONSTRAINT_VIOLATION = 1.0e6


class BudgetExhausted(RuntimeError):
    """More real evaluations were requested than the budget allows."""


@dataclass
class EvaluatedBatch:
    """One batch of real evaluations as an algorithm sees it.

    ``F`` and ``G`` are finite: failed designs carry a penalty (worst finite objective
    value seen so far and a large constraint violation); ``failed`` tells surrogate-based
    algorithms which rows to leave out of their training data.
    """

    X: np.ndarray
    F: np.ndarray
    G: np.ndarray
    failed: np.ndarray
    reason: list[str]


class Evaluator:
    """Counts, archives and sanitises real evaluations of one problem.

    Args:
        problem: The problem to evaluate.
        budget: Maximum number of real evaluations (>= 1).
        archive: Where to persist evaluations (None: keep in memory only).
        replay: Evaluations of an interrupted run to answer from before calling the problem.
        damaged: ``(start, stop)`` row ranges of ``replay`` that failed their checksums;
            a batch touching them is evaluated again for real.
        seed: Recorded with every evaluation (problems with noise use their own seed).
        time_limit: Seconds allowed per design (None: no limit). With a limit, evaluations
            run in a worker process (:mod:`tmopt.evaluation.isolation`); a design that
            overruns it is marked failed and the run goes on.
    """

    def __init__(self, problem: ExpensiveProblem, budget: int,
                 archive: EvaluationArchive | None = None,
                 replay: ArchiveData | None = None, seed: int = 0,
                 time_limit: float | None = None, damaged=()) -> None:
        if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 1:
            raise ValueError(f"budget must be an integer >= 1, got {budget!r}")
        self.problem = problem
        self.budget = int(budget)
        self.seed = int(seed)
        self.archive = archive if archive is not None else EvaluationArchive(
            "", problem.n_var, problem.n_obj, problem.n_ieq_constr)
        self._persist = archive is not None
        self._replay = replay
        self._untrusted = np.zeros(0 if replay is None else len(replay), dtype=bool)
        for start, stop in damaged:
            self._untrusted[start:stop] = True
        self.n_reevaluated = 0  # damaged archive rows evaluated again
        self.n_batches = 0
        self._isolated = IsolatedProblem(problem, time_limit) if time_limit else None
        if replay is not None and len(replay) > self.budget:
            raise ArchiveError(f"the archive holds {len(replay)} evaluations, more than "
                               f"budget={self.budget}; it belongs to a larger run")

    # ---- counters ----------------------------------------------------------------------
    @property
    def n_evals(self) -> int:
        return len(self.archive)

    @property
    def remaining(self) -> int:
        return self.budget - self.n_evals

    @property
    def n_replayed_left(self) -> int:
        return 0 if self._replay is None else max(len(self._replay) - self.n_evals, 0)

    def replayed_designs(self, n: int) -> np.ndarray | None:
        """The next ``n`` archived designs while a resume replays, else None.

        An algorithm whose proposal is costly and whose state does not depend on how a
        proposal was computed (only on the seeded draws and the evaluated designs) may
        propose these instead of recomputing them (:meth:`Algorithm.replayed`).
        """
        if n < 1 or self.n_replayed_left < n \
                or self._untrusted[self.n_evals:self.n_evals + n].any():
            return None
        return self._replay.rows(self.n_evals, self.n_evals + n).X.copy()

    # ---- evaluation --------------------------------------------------------------------
    def evaluate(self, X: np.ndarray) -> EvaluatedBatch:
        """Evaluate designs for real (or from the replay archive) and archive them."""
        X = self._checked_designs(X)
        if len(X) > self.remaining:
            raise BudgetExhausted(f"problem {self.problem.name}: {len(X)} evaluations asked, "
                                  f"only {self.remaining} of budget={self.budget} left")
        replaying = self.n_replayed_left > 0
        rows = self._from_replay(X) if replaying else self._evaluate_for_real(X)
        rows.batch = np.full(len(X), self.n_batches, dtype=np.int64)
        self.n_batches += 1
        # While replaying, the file on disk still holds the whole interrupted archive, a
        # superset of what is in memory: rewriting it now would drop the not yet replayed
        # tail if this run were killed too. The first real batch writes everything.
        if self._persist and not replaying:
            self.archive.append(rows)
        else:
            self.archive.data.append(rows)
        return sanitise(rows, self.archive.data)

    def _checked_designs(self, X) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[1] != self.problem.n_var or len(X) == 0:
            raise ValueError(f"problem {self.problem.name}: designs must have shape "
                             f"(n >= 1, {self.problem.n_var}), got {X.shape}")
        if not np.all(np.isfinite(X)):
            raise ValueError(f"problem {self.problem.name}: designs contain NaN or inf")
        return X

    def _from_replay(self, X: np.ndarray) -> ArchiveData:
        start = self.n_evals
        if len(X) > self.n_replayed_left:
            raise ArchiveError(
                f"resume: the algorithm asked for a batch of {len(X)} at evaluation {start}, "
                f"but the archive ends {self.n_replayed_left} evaluations later mid-batch; "
                "it was written by a different algorithm configuration")
        stop = start + len(X)
        if self._untrusted[start:stop].any():
            log.warning("resume: archive rows %d-%d failed their checksum; evaluating this "
                        "batch again", start, stop - 1)
            self.n_reevaluated += len(X)
            return self._evaluate_for_real(X)
        rows = self._replay.rows(start, stop)
        if not np.array_equal(rows.X, X):
            if self.n_reevaluated:  # the re-evaluated values differ from the lost ones
                log.warning("resume: after re-evaluating damaged rows the algorithm asks for "
                            "other designs at evaluation %d; the %d archived rows from there "
                            "on are dropped and evaluated anew", start, len(self._replay) - start)
                self._replay = self._replay.rows(0, start)
                return self._evaluate_for_real(X)
            raise ArchiveError(
                f"resume: the designs asked for at evaluation {start} differ from the "
                "archived ones, so the archive belongs to a different configuration or seed")
        return rows

    def _evaluate_for_real(self, X: np.ndarray) -> ArchiveData:
        t0 = time.perf_counter()
        rows = np.arange(self.n_evals, self.n_evals + len(X))
        try:
            F, G, reason, noise = self._call_problem(X, rows)
        except Exception as exc:  # noqa: BLE001 - isolate the failing designs
            log.warning("problem %s: batch evaluation raised %r; evaluating designs one by one",
                        self.problem.name, exc)
            F, G, reason, noise = self._one_by_one(X, rows)
        wall = (time.perf_counter() - t0) / len(X)
        F, G, failed, reason = _mark_non_finite(F, G, reason)
        for i in np.flatnonzero(failed):
            log.warning("problem %s: design %d failed: %s", self.problem.name,
                        self.n_evals + i, reason[i])
        return ArchiveData(X=X.copy(), F=F, G=G, failed=failed, reason=reason,
                           seed=np.full(len(X), self.seed, dtype=np.int64),
                           wall_time=np.full(len(X), wall), batch=np.zeros(len(X), np.int64),
                           noise_seeds=noise)

    def flush(self, rewrite: bool = False) -> None:
        """Write the archive if this run repaired rows that the file still holds damaged
        (a replay that ends the run never reaches the first real batch that would), or
        when ``rewrite`` asks (a round-one archive gains its checksums)."""
        if self._persist and (self.n_reevaluated or rewrite) and self.n_replayed_left == 0:
            self.archive.save()

    def close(self) -> None:
        """Stop the evaluation worker, if any."""
        if self._isolated is not None:
            self._isolated.close()

    def _call_problem(self, X: np.ndarray, rows: np.ndarray):
        """``F, G, reason, noise_seeds`` of a batch.  The problem is told the batch's
        archive rows and the run seed (``rows=``, ``run_seed=``): a noisy problem draws
        its realisations from them (pymoo hands such keywords only to problems that set
        ``requires_kwargs``), so a re-evaluation of the same rows meets the same noise."""
        context = {"rows": rows, "run_seed": self.seed}
        out = self._isolated.evaluate(X, **context) if self._isolated is not None \
            else self.problem.evaluate(X, return_as_dictionary=True, **context)
        n, p = len(X), self.problem
        F = np.asarray(out["F"], dtype=float).reshape(n, p.n_obj)
        G = (np.asarray(out["G"], dtype=float).reshape(n, p.n_ieq_constr)
             if p.n_ieq_constr else np.zeros((n, 0)))
        reason = out.get("reason")
        reason = [str(r) if r is not None else "" for r in reason] if reason is not None \
            else [""] * n
        noise = out.get("noise_seeds")  # exact: every noise seed is below 2^53
        noise = np.zeros((n, 0), np.int64) if noise is None else \
            np.asarray(noise).astype(np.int64).reshape(n, -1)
        return F, G, reason, noise

    def _one_by_one(self, X: np.ndarray, rows: np.ndarray):
        p = self.problem
        F = np.full((len(X), p.n_obj), np.nan)
        G = np.full((len(X), p.n_ieq_constr), np.nan)
        reason = [""] * len(X)
        noise = [np.full((1, getattr(p, "seeds_per_evaluation", 0)), -1, np.int64)] * len(X)
        for i, x in enumerate(X):
            try:
                F[i:i + 1], G[i:i + 1], reason[i:i + 1], noise[i] = self._call_problem(
                    x[None, :], rows[i:i + 1])
            except EvaluationTimeout as exc:
                reason[i] = str(exc)
            except Exception as exc:  # noqa: BLE001 - one design failing must not end the run
                reason[i] = f"evaluation raised {type(exc).__name__}: {exc}"
        width = max(a.shape[1] for a in noise)
        return F, G, reason, np.vstack([np.pad(a, ((0, 0), (0, width - a.shape[1])),
                                               constant_values=-1) for a in noise])


def _mark_non_finite(F, G, reason):
    reason = list(reason)
    failed = np.array([bool(r) for r in reason], dtype=bool)
    bad = ~np.all(np.isfinite(F), axis=1) | ~np.all(np.isfinite(G), axis=1)
    for i in np.flatnonzero(bad & ~failed):
        reason[i] = "non-finite objective or constraint value"
    failed |= bad
    F = F.copy()
    G = G.copy()
    F[failed] = np.nan
    G[failed] = np.nan
    return F, G, failed, reason


def sanitise(rows: ArchiveData, history: ArchiveData) -> EvaluatedBatch:
    """Replace failed rows by finite penalties derived from the history (deterministic)."""
    F, G = rows.F.copy(), rows.G.copy()
    if rows.failed.any():
        ok = ~history.failed
        worst_f = np.max(history.F[ok], axis=0) if ok.any() else np.zeros(F.shape[1])
        span_f = np.ptp(history.F[ok], axis=0) if ok.sum() > 1 else np.ones(F.shape[1])
        F[rows.failed] = worst_f + np.maximum(span_f, 1.0)
        G[rows.failed] = FAILED_CONSTRAINT_VIOLATION
    return EvaluatedBatch(X=rows.X, F=F, G=G, failed=rows.failed.copy(), reason=list(rows.reason))
