"""The algorithm interface: ``setup`` once, then ``ask`` designs and ``tell`` their values.

An algorithm never evaluates the problem itself: the runner owns the real evaluations
(budget, archive, failures), so every algorithm spends the same budget the same way and
a killed run can be replayed. Surrogate-only work (fitting models, generations on the
models) happens inside ``ask``/``tell``.

Subclasses implement ``_setup``, ``_infill`` (pymoo's name for proposing designs) and
``_advance`` (updating the state with the evaluated batch), and may override
``initial_sample_size``, ``info`` and ``summary``. An algorithm whose state is costly to rebuild on
resume may checkpoint it (:meth:`Algorithm._write_checkpoint`, :attr:`Algorithm.resume_state`).
Constructors check their arguments with :func:`check_int` and :func:`check_number`, whose
messages name the algorithm, the argument, the allowed range and the value.
"""

from __future__ import annotations

import hashlib
import io
import logging
import random
from abc import ABC, abstractmethod
from pathlib import Path

import numpy as np
import torch

from tmopt.evaluation.evaluator import EvaluatedBatch
from tmopt.files import atomic_write_bytes
from tmopt.problems.base import ExpensiveProblem

log = logging.getLogger(__name__)

#: The run folder's algorithm checkpoint, beside ``archive.h5``.
CHECKPOINT_FILE = "algorithm_state.pt"


class AlgorithmConfigError(ValueError):
    """An algorithm was asked for something it cannot do (names the algorithm)."""


class Algorithm(ABC):
    """Base class of every optimiser in tmopt.

    Args:
        pop_size: Population size (>= 2); each algorithm's constructor has its default.
    """

    #: Short name used in configs, tables and messages.
    name: str = "algorithm"

    def __init__(self, *, pop_size: int) -> None:
        self.pop_size = check_int(self.name, "pop_size", pop_size, 2)
        self.problem: ExpensiveProblem | None = None
        self.n_gen = 0
        self.n_evals = 0

    # ---- public steps ----------------------------------------------------------------
    def setup(self, problem, budget: int | None = None, seed: int | None = 0,
              termination=None, **options) -> None:
        """Bind the problem, the real-evaluation budget and the seed; reset all state.

        ``problem`` may be any pymoo problem (wrapped by
        :func:`tmopt.problems.pymoo_problem.as_expensive`). pymoo's ``minimize`` calls this
        with ``termination=("n_evals", N)`` instead of ``budget`` and options ``verbose``
        and ``outdir``, then :meth:`run` (see :mod:`tmopt.algorithms.as_pymoo`); seed None
        draws one, as pymoo does.
        """
        from tmopt.algorithms.as_pymoo import budget_from, run_options
        from tmopt.problems.pymoo_problem import as_expensive

        self.user_problem = problem
        problem = as_expensive(problem)
        budget = budget_from(self.name, budget, termination)
        self.run_options = run_options(self.name, options)
        if seed is None:
            seed = int(np.random.SeedSequence().generate_state(1)[0] % 2**31)
        self.problem = problem
        self.budget = check_int(self.name, "budget", budget, 1)
        self.seed = check_int(self.name, "seed", seed, 0)
        self.rng = np.random.default_rng(seed)
        seed_everything(seed)
        self.check_budget(problem, budget)
        self.n_gen = 0
        self.n_evals = 0
        self._replay_source = None
        self._checkpoint_path: Path | None = None
        self._told = hashlib.sha256()  # digest of every design told so far, in order
        self.resume_state: dict | None = None
        self._setup()

    def attach_replay(self, source) -> None:
        """Let :meth:`replayed` read a resumed run's archive (``source(n)`` -> designs)."""
        self._replay_source = source

    def replayed(self, n: int) -> np.ndarray | None:
        """The next ``n`` designs of the archive being replayed on resume, else None.

        Only for proposals that are expensive to recompute and leave no trace in the
        state but the designs themselves (qLogNEHVI's acquisition optimisation): the
        resumed run then equals the uninterrupted one without redoing that work.
        """
        return None if self._replay_source is None else self._replay_source(n)

    def attach_checkpoint(self, path: str | Path, archived_X: np.ndarray | None = None) -> None:
        """Keep a checkpoint at ``path``; on a resume, offer the one there if it fits.

        A checkpoint records how many evaluations the algorithm had been told and a digest
        of their designs. It becomes :attr:`resume_state` only if ``archived_X`` (the
        designs of the archive being replayed) begins with exactly those designs, so one
        left by another run, seed or configuration is never used.
        """
        self._checkpoint_path = Path(path)
        self.resume_state = None
        if archived_X is not None and self._checkpoint_path.exists():
            self.resume_state = _matching_checkpoint(self._checkpoint_path, self.name,
                                                     np.asarray(archived_X, dtype=float))

    def _write_checkpoint(self, payload: dict) -> None:
        """Save ``payload`` (tensors, numbers, strings, lists, dicts) atomically, if attached."""
        if self._checkpoint_path is None:
            return
        buffer = io.BytesIO()
        torch.save({"algorithm": self.name, "n_evals": self.n_evals,
                    "digest": self._told.hexdigest(), "payload": payload}, buffer)
        atomic_write_bytes(self._checkpoint_path, buffer.getvalue())

    def ask(self) -> np.ndarray:
        """Designs (n, n_var) to evaluate for real next."""
        X = np.asarray(self._infill(), dtype=float)
        return np.clip(X, self.problem.xl, self.problem.xu)

    def tell(self, batch: EvaluatedBatch) -> None:
        """Feed back real evaluations of (a prefix of) the last ``ask``."""
        self.n_evals += len(batch.X)
        self._told.update(_design_bytes(batch.X))
        self._advance(batch)
        self.n_gen += 1

    def run(self):
        """Spend the budget bound by :meth:`setup` through tmopt's runner; a pymoo
        ``Result``. This is what pymoo's ``minimize`` calls
        (:func:`tmopt.algorithms.as_pymoo.run_algorithm` says what the result holds)."""
        from tmopt.algorithms.as_pymoo import run_algorithm

        return run_algorithm(self)

    def has_next(self) -> bool:
        """False when the algorithm has nothing more to propose (budget aside)."""
        return True

    def check_budget(self, problem: ExpensiveProblem, budget: int) -> None:
        """Raise :class:`AlgorithmConfigError` if ``budget`` cannot cover the initial sample."""
        need = self.initial_sample_size(problem)
        if budget < need:
            raise AlgorithmConfigError(
                f"algorithm {self.name}: budget={budget} is smaller than its initial sample "
                f"of {need} real evaluations on problem {problem.name}; raise the budget")

    def initial_sample_size(self, problem: ExpensiveProblem) -> int:
        """Real evaluations the algorithm needs before its first decision."""
        return self.pop_size

    def info(self) -> dict:
        """Short state for progress lines (e.g. stage, granularity)."""
        return {}

    def summary(self) -> dict:
        """The algorithm's own course over the run, for ``metrics.json`` (JSON values only;
        e.g. the stage MGSAEA reached and when). Empty for algorithms without one."""
        return {}

    # ---- to implement ----------------------------------------------------------------
    def _setup(self) -> None:
        """Prepare state after :meth:`setup` has bound problem, budget and seed."""

    @abstractmethod
    def _infill(self) -> np.ndarray:
        """Propose designs to evaluate for real."""

    @abstractmethod
    def _advance(self, batch: EvaluatedBatch) -> None:
        """Update the state with evaluated designs."""


def check_surrogate_factory(algorithm: str, surrogate):
    """``surrogate`` unchanged when None or callable (a zero-argument Surrogate factory)."""
    if surrogate is not None and not callable(surrogate):
        raise AlgorithmConfigError(f"algorithm {algorithm}: surrogate must be a "
                                   f"zero-argument factory, got {surrogate!r}")
    return surrogate


def check_int(algorithm: str, label: str, value, minimum: int) -> int:
    """``value`` as an int, or :class:`AlgorithmConfigError` unless an integer >= minimum."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise AlgorithmConfigError(f"algorithm {algorithm}: {label} must be an integer "
                                   f">= {minimum}, got {value!r}")
    return int(value)


def check_choice(algorithm: str, label: str, value, allowed: tuple[str, ...]) -> str:
    """``value``, or :class:`AlgorithmConfigError` unless it is one of ``allowed``."""
    if value not in allowed:
        raise AlgorithmConfigError(f"algorithm {algorithm}: {label} must be one of "
                                   f"{', '.join(allowed)}, got {value!r}")
    return value


def check_number(algorithm: str, label: str, value, low: float, high: float = np.inf,
                 low_open: bool = False) -> float:
    """``value`` as a float, or :class:`AlgorithmConfigError` unless in [low, high].

    ``low_open`` makes the lower end exclusive, (low, high].
    """
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.floating)) \
        and np.isfinite(value) and (value > low if low_open else value >= low) \
        and value <= high
    if not ok:
        bracket = "(" if low_open else "["
        upper = "inf)" if high == np.inf else f"{high}]"
        raise AlgorithmConfigError(f"algorithm {algorithm}: {label} must be a finite number "
                                   f"in {bracket}{low}, {upper}, got {value!r}")
    return float(value)


def _design_bytes(X: np.ndarray) -> bytes:
    return np.ascontiguousarray(X, dtype=np.float64).tobytes()


def _matching_checkpoint(path: Path, name: str, archived_X: np.ndarray) -> dict | None:
    """The payload at ``path`` if it was written by ``name`` after a prefix of ``archived_X``."""
    try:
        saved = torch.load(io.BytesIO(path.read_bytes()), weights_only=True)
        n = int(saved["n_evals"])
        fits = saved["algorithm"] == name and n <= len(archived_X) and saved["digest"] == \
            hashlib.sha256(_design_bytes(archived_X[:n])).hexdigest()
    except Exception as exc:  # noqa: BLE001 - a damaged checkpoint only costs time
        log.warning("ignoring the unreadable checkpoint %s (%s); the resume recomputes "
                    "the algorithm's state", path, exc)
        return None
    if not fits:
        log.warning("ignoring the checkpoint %s: it belongs to another run than the archive",
                    path)
        return None
    return saved["payload"]


def seed_everything(seed: int) -> None:
    """Seed Python, NumPy's legacy global state and torch (libraries that use them)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
