"""One optimisation run: ask -> evaluate (counted, archived) -> tell, until the budget is spent.

The runner is the only place that evaluates a problem for real. It writes into the run
folder as it goes (``archive.h5`` after every batch) and, at the end, the final
non-dominated set, the chosen solution (paper Eq. 21), ``metrics.json`` and plots (see
:mod:`tmopt.run.outputs`). Running the same command again in the same folder resumes an
interrupted run by replay (:mod:`tmopt.evaluation.evaluator`) and skips a finished one;
an algorithm that checkpoints its costly state (``algorithm_state.pt``) resumes from it.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

from tmopt.algorithms.base import CHECKPOINT_FILE, Algorithm
from tmopt.evaluation.archive import ArchiveData, ArchiveError, EvaluationArchive, read_archive
from tmopt.evaluation.evaluator import Evaluator
from tmopt.problems.base import ExpensiveProblem
from tmopt.run.progress import ProgressReporter

log = logging.getLogger(__name__)

ARCHIVE_FILE = "archive.h5"


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
) -> RunResult:
    """Run ``algorithm`` on ``problem`` for ``budget`` real evaluations.

    Args:
        problem: The problem (vectorised pymoo problem with constraint groups).
        algorithm: An un-setup :class:`~tmopt.algorithms.base.Algorithm`.
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
    """
    from tmopt.run.outputs import finished_metrics, write_outputs

    outdir = _prepare_outdir(outdir)
    if outdir is not None:
        done = finished_metrics(outdir, config_hash)
        if done is not None and resume:
            log.info("run in %s is already complete; nothing to do", outdir)
            return RunResult(read_archive(outdir / ARCHIVE_FILE), done, outdir, skipped=True)

    replay = _load_replay(outdir, config_hash, problem) if (outdir and resume) else None
    attrs = {"config_hash": config_hash, "problem": problem.name, "algorithm": algorithm.name,
             "seed": int(seed), "budget": int(budget)}
    archive = EvaluationArchive(outdir / ARCHIVE_FILE, problem.n_var, problem.n_obj,
                                problem.n_ieq_constr, attrs) if outdir else None
    evaluator = Evaluator(problem, budget, archive, replay=replay, seed=seed,
                          time_limit=eval_time_limit)
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
    reporter = ProgressReporter(budget, problem.objective_names, enabled=progress)
    t0 = time.perf_counter()
    try:
        while evaluator.remaining > 0 and algorithm.has_next():
            X = algorithm.ask()
            if len(X) == 0:
                break
            batch = _evaluate_or_explain(evaluator, X[: evaluator.remaining], outdir)
            algorithm.tell(batch)
            reporter.update(algorithm.n_gen, evaluator.archive.data, algorithm.info(),
                            replaying=evaluator.n_replayed_left > 0)
    finally:
        reporter.close()
        evaluator.close()
    data = evaluator.archive.data
    metrics = write_outputs(problem, algorithm, data, outdir, seed=seed, budget=budget,
                            wall_time=time.perf_counter() - t0, config_hash=config_hash,
                            resumed_from=resumed_from, plots=plots, extra_metrics=extra_metrics)
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
        probe = outdir / ".write-test"
        probe.write_text("ok")
        probe.unlink()
    except OSError as exc:
        raise OSError(f"output folder {outdir} is not writable: {exc.strerror or exc}") from exc
    return outdir


def _load_replay(outdir: Path, config_hash: str, problem: ExpensiveProblem) -> ArchiveData | None:
    path = outdir / ARCHIVE_FILE
    if not path.exists():
        return None
    data = read_archive(path)
    found = data.attrs.get("config_hash", "")
    if config_hash and found != config_hash:
        raise ArchiveError(
            f"{path} was written by a different configuration (hash {found or 'none'}, this "
            f"run {config_hash}); choose another output folder or pass resume=false to start over")
    if data.X.shape[1] != problem.n_var:
        raise ArchiveError(f"{path} holds designs of {data.X.shape[1]} variables, problem "
                           f"{problem.name} has {problem.n_var}")
    return data

