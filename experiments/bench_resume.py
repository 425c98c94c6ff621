"""How long a resumed run takes to catch up, with and without the algorithm's checkpoint.

    python experiments/bench_resume.py RUN_FOLDER

Copies the run folder's ``algorithm_state.pt`` and ``archive.h5`` (in that order, so a
run still going cannot leave a checkpoint newer than the copied archive) into a temporary
folder twice, deletes the checkpoint from one copy, and resumes both with the budget
set to the archive's length: each replays every archived evaluation and stops, so the
time is the catch-up alone (the problem is never called). Prints both times and their
ratio. (That the two end in the same state is what tests/algorithms/test_qlognehvi.py
checks, by continuing both past the archive.)
"""

from __future__ import annotations

import argparse
import logging
import shutil
import tempfile
import time
from pathlib import Path

from omegaconf import OmegaConf

from tmopt.algorithms.base import CHECKPOINT_FILE
from tmopt.evaluation.archive import read_archive
from tmopt.run.build import build
from tmopt.run.runner import ARCHIVE_FILE, run_optimisation


def catch_up(run: Path, copy: Path, keep_checkpoint: bool) -> tuple[float, object]:
    """Seconds to replay ``copy`` (a copy of ``run``) to its end, and the result."""
    cfg = OmegaConf.load(run / "config.yaml")
    n = len(read_archive(copy / ARCHIVE_FILE))
    if not keep_checkpoint:
        (copy / CHECKPOINT_FILE).unlink(missing_ok=True)
    problem, algorithm = build(cfg)
    start = time.perf_counter()
    result = run_optimisation(problem, algorithm, budget=n, seed=cfg.seed, outdir=copy,
                              config_hash="", resume=True, progress=False, plots=False)
    return time.perf_counter() - start, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a run folder with config.yaml, archive.h5 "
                        "and algorithm_state.pt")
    args = parser.parse_args()
    if not (args.run / CHECKPOINT_FILE).exists():
        parser.error(f"run={args.run} has no {CHECKPOINT_FILE} (only algorithms with a "
                     "costly state write one, e.g. qLogNEHVI)")
    logging.basicConfig(level=logging.WARNING)
    with tempfile.TemporaryDirectory() as tmp:
        copies = [Path(tmp) / "with", Path(tmp) / "without"]
        for copy in copies:
            copy.mkdir()
            shutil.copy2(args.run / CHECKPOINT_FILE, copy / CHECKPOINT_FILE)
        for copy in copies:
            shutil.copy2(args.run / ARCHIVE_FILE, copy / ARCHIVE_FILE)
        t_with, with_ckpt = catch_up(args.run, copies[0], keep_checkpoint=True)
        t_without, _ = catch_up(args.run, copies[1], keep_checkpoint=False)
    n = len(with_ckpt.archive.X)
    print(f"catch-up of {n} archived evaluations ({args.run.name})")
    print(f"  with the checkpoint:    {t_with:8.2f} s")
    print(f"  refitting (reference):  {t_without:8.2f} s")
    print(f"  ratio refit / checkpoint: {t_without / t_with:.1f}x")


if __name__ == "__main__":
    main()
