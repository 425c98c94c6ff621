"""Sweep-level resume: a re-run sweep launches only its unfinished runs.

Hydra launches every job of a multirun again (Hydra issue #3328 asks for more). tmopt's
run folders are deterministic and a run resumes by replay (docs/decisions.md, "Run
folders are deterministic; resuming is replay"), so before a sweep is launched each of
its runs is composed exactly as its launcher will compose it, its folder found and
looked at:

========== ==================================================== ============
state      the folder holds                                      launched?
========== ==================================================== ============
skipped    a complete run of the same configuration, its archive no
           intact (a finished run whose archive is missing or
           damaged is run again to restore it: resumed/started)
running    a run whose lock another live process holds           no
resumed    an archive of the same configuration, not complete    yes (replay)
blocked    an archive it cannot resume (another configuration,   yes: the run
           or resume=false over a complete run)                  says why
started    nothing yet, or only an unreadable archive (kept      yes
           aside as archive.h5.unreadable)
========== ==================================================== ============

This happens in tmopt's Hydra sweeper (``hydra/sweeper=tmopt``, the default of
``tmopt/conf/config.yaml``; ``hydra_plugins/tmopt_sweeper``), in front of whatever launcher the
sweep uses: a SLURM sweep no longer queues a job per finished run. Inside each job the
runner still skips a finished run (a job of an older sweep may finish meanwhile).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from omegaconf import DictConfig, OmegaConf, open_dict, read_write

from tmopt.evaluation.archive import ArchiveError, read_archive_checked
from tmopt.run.config import config_hash
from tmopt.run.outputs import finished_metrics
from tmopt.run.run_lock import describe_holder, lock_holder
from tmopt.run.runner import ARCHIVE_FILE, FolderOfAnotherRun, check_folder_owner

#: Order of the states in the summary line.
STATES = ("skipped", "running", "resumed", "blocked", "started")
NOT_LAUNCHED = ("skipped", "running")


@dataclass(frozen=True)
class JobTarget:
    """Where one job of a sweep runs and what it is (from its composed configuration)."""

    outdir: Path
    config_hash: str
    resume: bool


@dataclass(frozen=True)
class RunPlan:
    """One job of a sweep and what the sweep does with it."""

    overrides: tuple[str, ...]
    outdir: Path
    state: str
    archived: int = 0  # real evaluations already in its archive
    why: str = ""  # for running/blocked: who holds it, what is wrong

    @property
    def launch(self) -> bool:
        return self.state not in NOT_LAUNCHED


def classify_run(target: JobTarget) -> tuple[str, int, str]:
    """State of one run folder: ``(state, archived evaluations, why)`` (see module doc)."""
    outdir = target.outdir
    holder = lock_holder(outdir) if outdir.is_dir() else None
    if holder is not None:
        return "running", 0, f"in use by {describe_holder(holder)}"
    try:
        check_folder_owner(outdir, target.config_hash, target.resume)
    except FolderOfAnotherRun:
        return "blocked", _archived(outdir), "folder of another configuration"
    finished = finished_metrics(outdir, target.config_hash) is not None
    if finished and not target.resume:
        return "blocked", 0, "complete, and resume=false starts it over"
    if not (outdir / ARCHIVE_FILE).exists():
        # a finished run whose archive is gone is run again to restore it (runner.py)
        return "started", 0, "archive missing" if finished else ""
    try:
        data, damaged = read_archive_checked(outdir / ARCHIVE_FILE)
    except (ArchiveError, OSError) as exc:
        return "started", 0, f"unreadable archive kept aside and started over: {exc}"
    if finished and not damaged:
        return "skipped", 0, ""
    found = data.attrs.get("config_hash", "")
    if target.config_hash and found != target.config_hash:
        return "blocked", len(data), "archive of another configuration"
    if not target.resume:
        return "blocked", len(data), "resume=false starts it over"
    if len(data) == 0:
        return "started", 0, ""
    rows = sum(d.stop - d.start for d in damaged)
    return "resumed", len(data), f"{rows} damaged rows evaluated again" if damaged else ""


def _archived(outdir: Path) -> int:
    try:
        return len(read_archive_checked(outdir / ARCHIVE_FILE)[0])
    except (ArchiveError, OSError):
        return 0


def plan_sweep(jobs: Sequence[Sequence[str]],
               target_of: Callable[[Sequence[str]], JobTarget]) -> list[RunPlan]:
    """Classify every job (its overrides) of a sweep; ``target_of`` composes one job."""
    plans = []
    for overrides in jobs:
        target = target_of(overrides)
        state, archived, why = classify_run(target)
        plans.append(RunPlan(tuple(overrides), target.outdir, state, archived, why))
    return plans


def summary_line(plans: Sequence[RunPlan]) -> str:
    """One line: how many runs the sweep has and what happens to each kind.

    E.g. ``tmopt sweep: 12 runs: 9 skipped (complete), 1 resumed (40 archived
    evaluations), 2 started; launching 3``.
    """
    count = {s: sum(p.state == s for p in plans) for s in STATES}
    archived = sum(p.archived for p in plans if p.state == "resumed")
    parts = [f"{count['skipped']} skipped (complete)"]
    if count["running"]:
        parts.append(f"{count['running']} running elsewhere (not launched)")
    parts.append(f"{count['resumed']} resumed ({archived} archived evaluations)")
    if count["blocked"]:
        parts.append(f"{count['blocked']} blocked (launched to report why)")
    parts.append(f"{count['started']} started")
    launched = sum(p.launch for p in plans)
    return f"tmopt sweep: {len(plans)} runs: {', '.join(parts)}; launching {launched}"


def detail_lines(plans: Sequence[RunPlan]) -> list[str]:
    """One line per run that is neither started nor skipped (running, resumed, blocked)."""
    return [f"  {p.state}: {p.outdir}" + (f" ({p.why})" if p.why else
                                           f" (from {p.archived} evaluations)")
            for p in plans if p.state in ("running", "resumed", "blocked")]


def job_target(config: DictConfig) -> JobTarget:
    """Folder, configuration hash and resume flag of one job's composed sweep config.

    Mirrors what Hydra's ``run_job`` and :func:`tmopt.run.cli.run_from_config` do with it: the
    folder is ``hydra.sweep.dir / hydra.sweep.subdir`` evaluated with the job's own Hydra
    config in place, the hash is that of the task configuration (``hydra`` removed).
    """
    from hydra.core.hydra_config import HydraConfig

    hc = HydraConfig.instance()
    saved = hc.cfg
    hc.set_config(config)
    try:
        outdir = Path(str(OmegaConf.select(config, "hydra.sweep.dir"))) / str(
            OmegaConf.select(config, "hydra.sweep.subdir"))
        task = copy.deepcopy(config)
        with read_write(task), open_dict(task):
            del task["hydra"]
        return JobTarget(outdir, config_hash(task), bool(task.get("resume", True)))
    finally:
        hc.cfg = saved

