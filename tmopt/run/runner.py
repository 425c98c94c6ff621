"""One optimisation run: ask -> evaluate (counted, archived) -> tell, until the budget is spent.

The runner is the only place that evaluates a problem for real. It writes into the run
folder as it goes (``archive.h5`` after every batch) and, at the end, the final
non-dominated set, the chosen solution (paper Eq. 21), ``metrics.json`` and plots (see
:mod:`tmopt.run.outputs`). Running the same command again in the same folder resumes an
interrupted run by replay (:mod:`tmopt.evaluation.evaluator`) and skips a finished one;
an algorithm that checkpoints its costly state (``algorithm_state.pt``) resumes from it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from tmopt.algorithms.base import CHECKPOINT_FILE, Algorithm
from tmopt.evaluation.archive import (
    ArchiveData,
    ArchiveError,
    EvaluationArchive,
    has_checksums,
    read_archive,
    read_archive_checked,
)
from tmopt.evaluation.evaluator import Evaluator
from tmopt.files import atomic_write_text, remove_stale_temporaries
from tmopt.problems.base import ExpensiveProblem
from tmopt.run.progress import ProgressReporter
from tmopt.run.run_lock import hold_run_lock

log = logging.getLogger(__name__)

ARCHIVE_FILE = "archive.h5"
#: Where an archive that cannot be read at all is kept when the run starts over.
UNREADABLE_SUFFIX = ".unreadable"


class FolderOfAnotherRun(ArchiveError):
    """The run folder holds a run of another configuration: refused, the folder untouched."""


@dataclass
class RunResult:
    """What a finished run produced (also on disk in its folder)."""

    archive: ArchiveData
    metrics: dict
    outdir: Path | None
    resumed_from: int = 0
    skipped: bool = False


def run_optimisation(
    problem: ExpensiveProblem,
    algorithm: Algorithm,
    budget: int,
    seed: int = 0,
    outdir: str | Path | None = None,
    config_hash: str = "",
    resume: bool = True,
    progress: bool = True,
    plots: bool = True,
    extra_metrics=None,
    eval_time_limit: float | None = None,
    config_text: str | None = None,
) -> RunResult:
    """Run ``algorithm`` on ``problem`` for ``budget`` real evaluations.

    Args:
        problem: A tmopt :class:`ExpensiveProblem` or any pymoo problem (wrapped by
            :func:`~tmopt.problems.pymoo_problem.as_expensive`).
        algorithm: A tmopt :class:`~tmopt.algorithms.base.Algorithm` or any pymoo
            algorithm (wrapped by :func:`~tmopt.algorithms.pymoo_adapter.as_tmopt_algorithm`).
        budget: Real evaluations allowed.
        seed: Seeds the algorithm (and is recorded with every evaluation).
        outdir: Run folder; None keeps everything in memory.
        config_hash: Identifies the configuration; a resumed archive must carry the same.
        resume: Reuse an existing archive in ``outdir`` (replay) instead of refusing it.
        progress: Print one progress line (or bar) per generation.
        plots: Write PNG plots at the end.
        extra_metrics: Optional callable ``(problem, archive, pareto_idx) -> dict`` merged
            into ``metrics.json`` (e.g. simulator-specific numbers).
        eval_time_limit: Seconds allowed per design evaluation (None: no limit).
        config_text: Written to ``config.yaml`` once the folder is known to be this run's.

    The run holds the folder's lock (:mod:`tmopt.run.run_lock`) from its first look at
    the folder to its last write: a second process on the same folder is refused.

    Raises:
        FolderOfAnotherRun: ``outdir`` holds a run of another configuration (untouched).
        RunFolderBusy: another live process runs in ``outdir``.
    """
    from tmopt.algorithms.pymoo_adapter import as_tmopt_algorithm
    from tmopt.problems.pymoo_problem import as_expensive

    problem, algorithm = as_expensive(problem), as_tmopt_algorithm(algorithm)
    outdir = _prepare_outdir(outdir)
    if outdir is not None:  # refuse before touching anything, and again under the lock
        check_folder_owner(outdir, config_hash, resume)
    with hold_run_lock(outdir) if outdir is not None else contextlib.nullcontext():
        return _run_locked(problem, algorithm, budget, seed, outdir, config_hash, resume,
                           progress, plots, extra_metrics, eval_time_limit, config_text)


def _run_locked(problem, algorithm, budget, seed, outdir, config_hash, resume, progress,
                plots, extra_metrics, eval_time_limit, config_text) -> RunResult:
    from tmopt.run.outputs import reference_front, write_outputs

    replay, damaged = None, []
    if outdir is not None:
        for tmp in remove_stale_temporaries(outdir):
            log.info("removed %s, left by a writer that was killed", tmp.name)
        check_folder_owner(outdir, config_hash, resume)
        done = _finished_run(outdir, config_hash) if resume else None
        if done is not None:
            return done
        if resume:
            replay, damaged = _load_replay(outdir, problem)
        if config_text is not None:
            atomic_write_text(outdir / "config.yaml", config_text)
    attrs = {"config_hash": config_hash, "problem": problem.name, "algorithm": algorithm.name,
             "seed": int(seed), "budget": int(budget)}
    archive = EvaluationArchive(outdir / ARCHIVE_FILE, problem.n_var, problem.n_obj,
                                problem.n_ieq_constr, attrs) if outdir else None
    evaluator = Evaluator(problem, budget, archive, replay=replay, seed=seed,
                          time_limit=eval_time_limit, damaged=damaged)
    resumed_from = 0 if replay is None else len(replay)
    if resumed_from:
        log.info("resuming from %d archived evaluations in %s (replayed, not re-evaluated)",
                 resumed_from, outdir)

    algorithm.setup(problem, budget=budget, seed=seed)
    if resumed_from:
        algorithm.attach_replay(evaluator.replayed_designs)
    if outdir is not None:
        algorithm.attach_checkpoint(outdir / CHECKPOINT_FILE,
                                    replay.X if replay is not None else None)
    reporter = ProgressReporter(budget, problem.objective_names, enabled=progress,
                                front=reference_front(problem) if progress else None,
                                m_weights=getattr(problem, "m_weights", None))
    t0 = time.perf_counter()
    clock: list[tuple[int, float]] = []  # (evaluations, seconds) per generation
    try:
        while evaluator.remaining > 0 and algorithm.has_next():
            X = algorithm.ask()
            if len(X) == 0:
                break
            batch = _evaluate_or_explain(evaluator, X[: evaluator.remaining], outdir)
            algorithm.tell(batch)
            clock.append((evaluator.n_evals, time.perf_counter() - t0))
            reporter.update(algorithm.n_gen, evaluator.archive.data, algorithm.info(),
                            replaying=evaluator.n_replayed_left > 0)
        evaluator.flush(rewrite=replay is not None and not has_checksums(replay))
    finally:
        reporter.close()
        evaluator.close()
    data = evaluator.archive.data
    metrics = write_outputs(problem, algorithm, data, outdir, seed=seed, budget=budget,
                            wall_time=time.perf_counter() - t0, config_hash=config_hash,
                            resumed_from=resumed_from, plots=plots, extra_metrics=extra_metrics,
                            clock=clock)
    return RunResult(data, metrics, outdir, resumed_from=resumed_from)


def _evaluate_or_explain(evaluator: Evaluator, X, outdir: Path | None):
    """Evaluate a batch; if its archive write fails, say what is safe on disk."""
    safe = evaluator.n_evals
    try:
        return evaluator.evaluate(X)
    except OSError as exc:
        raise OSError(exc.errno, f"cannot write the evaluation archive in {outdir}: "
                      f"{exc.strerror or exc}; the {safe} evaluations archived before are "
                      "intact and running the same command again resumes from them") from exc


def _prepare_outdir(outdir) -> Path | None:
    if outdir is None:
        return None
    outdir = Path(outdir)
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        # a probe of its own: two runs started together must not remove each other's
        with tempfile.NamedTemporaryFile(dir=outdir, prefix=".write-test-"):
            pass
    except OSError as exc:
        raise OSError(f"output folder {outdir} is not writable: {exc.strerror or exc}") from exc
    return outdir


def check_folder_owner(outdir: Path, config_hash: str, resume: bool = True) -> None:
    """Refuse a folder that holds a run of another configuration (its archive or its
    finished metrics say so), unless ``resume=false`` asks to start over.

    Raises:
        FolderOfAnotherRun: naming the folder, both hashes and the way out.
    """
    from tmopt.run.outputs import METRICS_FILE, read_metrics

    if not resume or not config_hash:
        return
    found = None
    metrics = read_metrics(outdir)
    if metrics is not None and metrics.get("config_hash") not in (None, "", config_hash):
        found = f"a finished run of configuration {metrics['config_hash']} ({METRICS_FILE})"
    else:
        owner = _archive_owner(outdir / ARCHIVE_FILE)
        if owner not in (None, "", config_hash):
            found = f"the archive of configuration {owner} ({ARCHIVE_FILE})"
    if found:
        raise FolderOfAnotherRun(
            f"output folder {outdir} holds {found}, not this run's ({config_hash}); choose "
            "another output folder (hydra.run.dir=...) or pass resume=false to start over")


def _archive_owner(path: Path) -> str | None:
    """The configuration hash an archive was written by (None: no readable archive)."""
    try:
        import h5py

        with h5py.File(path, "r") as h5:
            value = h5.attrs.get("config_hash")
    except Exception:  # noqa: BLE001 - unreadable: the run keeps it aside (_load_replay)
        return None
    return value.decode() if isinstance(value, bytes) else (None if value is None else str(value))


def _finished_run(outdir: Path, config_hash: str) -> RunResult | None:
    """The finished run of this configuration in ``outdir``; None if there is none, or if
    its archive is gone or damaged (then the run is made again: same result, the archive
    restored) rather than failing until someone deletes metrics.json by hand."""
    from tmopt.run.outputs import finished_metrics

    done = finished_metrics(outdir, config_hash)
    if done is None:
        return None
    try:
        data = read_archive(outdir / ARCHIVE_FILE)
    except (ArchiveError, OSError) as exc:
        reason = "is missing" if not (outdir / ARCHIVE_FILE).exists() else f"is unusable ({exc})"
        log.warning("the run in %s is complete but its archive %s; running it again to "
                    "restore it (same configuration and seed, same result)", outdir, reason)
        return None
    log.info("run in %s is already complete; nothing to do", outdir)
    return RunResult(data, done, outdir, skipped=True)


def _load_replay(outdir: Path, problem: ExpensiveProblem) -> tuple[ArchiveData | None, list]:
    """The archive to resume from and its damaged row ranges (``(start, stop)``).

    An archive that cannot be read at all is renamed ``archive.h5.unreadable`` (kept for
    inspection, never deleted) and the run starts over, with a warning."""
    path = outdir / ARCHIVE_FILE
    if not path.exists():
        return None, []
    try:
        data, damaged = read_archive_checked(path)
    except ArchiveError as exc:
        aside = path.with_name(path.name + UNREADABLE_SUFFIX)
        os.replace(path, aside)
        log.warning("%s; it is kept as %s and the run starts over", exc, aside.name)
        return None, []
    if data.X.shape[1] != problem.n_var:
        raise ArchiveError(f"{path} holds designs of {data.X.shape[1]} variables, problem "
                           f"{problem.name} has {problem.n_var}")
    for d in damaged:
        log.warning("%s: archive %s changed on disk since written (checksum mismatch); "
                    "these rows are evaluated again", path, d.describe())
    return data, [(d.start, d.stop) for d in damaged]
