"""A run folder in use: an advisory lock held by the process that runs it.

Killing a sweep's command does not stop the jobs it has handed to SLURM, and a sweep may
be re-run while some of them still run. Two processes on one run folder would do the same
work twice (replay keeps the archive right, but the cost is real), so the process running
a run holds an exclusive ``flock`` on ``run.lock`` in its folder for as long as it runs,
and writes who it is into the file (host, pid, SLURM job). The sweep filter
(:mod:`tmopt.run.sweep_resume`) leaves a locked run alone and a second process refuses it.

The lock dies with its process (the kernel releases it, even on SIGKILL), so nothing
stale is ever left to clean up. Where the file system has no ``flock`` (some network file
systems), runs go on unlocked: the lock is a guard against waste, never a condition of
correctness.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

LOCK_FILE = "run.lock"
#: errnos meaning "this file system has no flock": run unlocked rather than fail.
_NO_LOCKING = {errno.ENOLCK, errno.ENOSYS, errno.EOPNOTSUPP, errno.EINVAL}


class RunFolderBusy(RuntimeError):
    """Another process holds the run folder's lock."""


def slurm_job_id() -> str | None:
    """This process's SLURM job as ``scancel`` names it (``<array>_<task>`` in an array)."""
    array, task = os.environ.get("SLURM_ARRAY_JOB_ID"), os.environ.get("SLURM_ARRAY_TASK_ID")
    if array and task:
        return f"{array}_{task}"
    return os.environ.get("SLURM_JOB_ID")


@contextlib.contextmanager
def hold_run_lock(outdir: str | Path) -> Iterator[None]:
    """Hold ``outdir``'s run lock for the duration of the block.

    Raises:
        RunFolderBusy: another live process holds it (the message names that process).
    """
    path = Path(outdir) / LOCK_FILE
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RunFolderBusy(f"run folder {outdir} is in use by {_describe(path)}") from None
        except OSError as exc:
            if exc.errno not in _NO_LOCKING:
                raise
        holder = {"host": socket.gethostname(), "pid": os.getpid(),
                  "slurm_job": slurm_job_id(), "since": time.strftime("%Y-%m-%dT%H:%M:%S")}
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(holder).encode(), 0)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def lock_holder(outdir: str | Path) -> dict | None:
    """Who holds ``outdir``'s run lock (host, pid, slurm_job), or None when nobody does."""
    path = Path(outdir) / LOCK_FILE
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return _read_holder(path)
        except OSError as exc:
            if exc.errno in _NO_LOCKING:
                return None
            raise
        return None
    finally:
        os.close(fd)


def _read_holder(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}  # held, but the holder has not written its name yet


def _describe(path: Path) -> str:
    h = _read_holder(path)
    if not h:
        return "another process"
    job = f", SLURM job {h['slurm_job']}" if h.get("slurm_job") else ""
    return f"process {h.get('pid')} on {h.get('host')}{job} (since {h.get('since')})"
