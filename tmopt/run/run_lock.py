"""A run folder in use: one process at a time runs it, the others refuse in one line.

Killing a sweep's command does not stop the jobs it has handed to SLURM, a sweep may be
re-run while some of them still run, and a user may start two runs into one folder. Two
processes on one run folder would do the work twice or, with different seeds, leave one
of the two results (docs/decisions.md, "Run-folder locks"). The process running a run
therefore holds two locks for as long as it runs:

``run.lock`` (``flock``)
    The kernel's lock: freed when its process dies, even on SIGKILL. It is all that is
    needed on a local disk, but some shared file systems have no ``flock`` (NFS mounted
    without lock support) or keep it to one host (Lustre's ``localflock``).
``run.lease`` (a file created with ``O_EXCL``)
    Works wherever ``O_EXCL`` creation is atomic (local disks, NFS v3+, Lustre, GPFS).
    It names the holder (host, pid, SLURM job, start time, a random token) and its
    modification time is its heartbeat, refreshed every :data:`HEARTBEAT_S` seconds. A
    lease left by a dead process is taken over only when that is provable: on the same
    host its pid is gone (or ``run.lock`` is free, which a live holder would hold); on
    another host it is the same SLURM job (requeued: SLURM never runs one job twice at
    once) or its heartbeat is older than :data:`STALE_AFTER_S`.

The holder's details are written into both files, so the refusal names it:
``run folder <dir> is in use by process <pid> on <host>[, SLURM job <id>] (since <time>)``.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import logging
import os
import socket
import threading
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

log = logging.getLogger(__name__)

LOCK_FILE = "run.lock"
LEASE_FILE = "run.lease"
#: Seconds between two heartbeats of a held lease (its modification time).
HEARTBEAT_S = 30.0
#: A lease of another host whose heartbeat is older than this is taken over. Ten missed
#: heartbeats: far beyond clock differences between cluster nodes and NFS attribute caching.
STALE_AFTER_S = 300.0
#: errnos meaning "this file system has no flock": the lease alone guards the folder.
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
    """Hold ``outdir``'s run lock (flock and lease) for the duration of the block.

    Raises:
        RunFolderBusy: another live process holds it (the message names that process).
    """
    outdir = Path(outdir)
    path = outdir / LOCK_FILE
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        flocked = _try_flock(fd, fcntl.LOCK_EX)
        if flocked is None:
            raise RunFolderBusy(f"run folder {outdir} is in use by "
                                f"{describe_holder(_holder_of(outdir))}")
        holder = {"host": socket.gethostname(), "pid": os.getpid(),
                  "slurm_job": slurm_job_id(), "since": time.strftime("%Y-%m-%dT%H:%M:%S"),
                  "token": uuid.uuid4().hex}
        lease = _take_lease(outdir, holder, flocked)
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(holder).encode(), 0)
        stop = threading.Event()
        beat = threading.Thread(target=_heartbeat, args=(lease, holder["token"], stop),
                                name="tmopt-run-lease", daemon=True)
        beat.start()
        try:
            yield
        finally:
            stop.set()
            beat.join()
            _release_lease(lease, holder["token"])
    finally:
        os.close(fd)  # closing releases the flock


def lock_holder(outdir: str | Path) -> dict | None:
    """Who holds ``outdir``'s run lock (host, pid, slurm_job, since), or None when nobody
    does (no lock, or only the stale lease of a dead process)."""
    outdir = Path(outdir)
    path = outdir / LOCK_FILE
    flocked = False
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        fd = None
    if fd is not None:
        try:
            flocked = _try_flock(fd, fcntl.LOCK_SH)
            if flocked is None:
                return _read_json(path)
        finally:
            os.close(fd)
    lease = _read_lease(outdir / LEASE_FILE)
    if lease is None or _stale(lease, flocked) is not None:
        return None
    return lease


def describe_holder(h: dict) -> str:
    """``process <pid> on <host>[, SLURM job <id>] (since <time>)`` for a lock holder."""
    if not h:
        return "another process"
    job = f", SLURM job {h['slurm_job']}" if h.get("slurm_job") else ""
    return f"process {h.get('pid')} on {h.get('host')}{job} (since {h.get('since')})"


# ---- flock -----------------------------------------------------------------------------
def _try_flock(fd: int, kind: int) -> bool | None:
    """True: locked; False: this file system has no flock; None: held by another process."""
    try:
        fcntl.flock(fd, kind | fcntl.LOCK_NB)
    except BlockingIOError:
        return None
    except OSError as exc:
        if exc.errno not in _NO_LOCKING:
            raise
        return False
    return True


# ---- the lease -------------------------------------------------------------------------
def _take_lease(outdir: Path, holder: dict, flocked: bool) -> Path:
    path = outdir / LEASE_FILE
    for _ in range(3):  # a stale lease removed, then created by us or found taken again
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            current = _read_lease(path)
            if current is None:  # removed meanwhile: try again
                continue
            why = _stale(current, flocked)
            if why is None:
                raise RunFolderBusy(f"run folder {outdir} is in use by "
                                    f"{describe_holder(current)}") from None
            if _remove_stale(path, current):
                log.warning("run folder %s: took over the lock of %s (%s)", outdir,
                            describe_holder(current), why)
            continue
        try:
            os.write(fd, json.dumps(holder).encode())
            os.fsync(fd)
        finally:
            os.close(fd)
        return path
    raise RunFolderBusy(f"run folder {outdir} is in use by "
                        f"{describe_holder(_read_lease(path) or {})}")


def _stale(lease: dict, flocked: bool) -> str | None:
    """Why the holder of ``lease`` is provably gone, or None if it may be alive."""
    age = lease.get("heartbeat_age_s", 0.0)
    if not lease.get("token"):  # created, not yet written: its writer is at work or died
        return f"no holder written for {age:.0f} s" if age > STALE_AFTER_S else None
    if lease.get("host") == socket.gethostname():
        if flocked:
            return "its process holds no flock on run.lock"
        if not _pid_alive(lease.get("pid")):
            return f"process {lease.get('pid')} is gone"
        if age > STALE_AFTER_S:
            return f"no heartbeat for {age:.0f} s (its pid is used by another process)"
        return None
    job = slurm_job_id()
    if job and lease.get("slurm_job") == job:
        return f"SLURM job {job} was requeued"
    if age > STALE_AFTER_S:
        return f"no heartbeat for {age:.0f} s"
    return None


def _pid_alive(pid) -> bool:
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except (PermissionError, TypeError, ValueError):
        return True  # another user's process, or no pid: assume alive
    return True


def _read_lease(path: Path) -> dict | None:
    """The lease's holder with ``heartbeat_age_s``; None if there is no lease."""
    try:
        age = time.time() - path.stat().st_mtime
    except FileNotFoundError:
        return None
    return {**_read_json(path), "heartbeat_age_s": max(age, 0.0)}


def _remove_stale(path: Path, judged: dict) -> bool:
    """Remove the lease judged stale, unless it was replaced meanwhile (then restore it).

    Renaming is atomic and only one of several processes can rename the same file; the
    renamed file is checked to be the one judged stale, so a fresh lease created between
    the judgement and the rename is put back instead of being stolen."""
    aside = path.with_name(f"{path.name}.stale-{uuid.uuid4().hex}")
    try:
        os.rename(path, aside)
    except FileNotFoundError:
        return False
    if _read_json(aside).get("token") != judged.get("token"):
        with contextlib.suppress(FileExistsError):
            os.link(aside, path)
        os.unlink(aside)
        return False
    os.unlink(aside)
    return True


def _heartbeat(path: Path, token: str, stop: threading.Event) -> None:
    warned = False
    while not stop.wait(HEARTBEAT_S):
        if _read_json(path).get("token") == token:
            with contextlib.suppress(OSError):
                os.utime(path)
        elif not warned:
            log.error("run lease %s was taken over by %s while this process held it "
                      "(suspended for more than %.0f s?)", path,
                      describe_holder(_read_json(path)), STALE_AFTER_S)
            warned = True


def _release_lease(path: Path, token: str) -> None:
    if _read_json(path).get("token") == token:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)


#: How long a process that found the flock held waits for the holder to write its name
#: (the holder flocks first, then writes lease and lock file: a few ms, longer on a loaded
#: machine -- two runs started together on 2 busy cores read an empty lock file).
HOLDER_WAIT_S = 2.0


def _holder_of(outdir: Path) -> dict:
    """The holder named in the lock file (or else the lease), waiting up to HOLDER_WAIT_S
    for it to be written; ``{}`` if it never is (described as "another process")."""
    deadline = time.monotonic() + HOLDER_WAIT_S
    while True:
        holder = _read_json(outdir / LOCK_FILE) or _read_json(outdir / LEASE_FILE)
        if holder or time.monotonic() > deadline:
            return holder
        time.sleep(0.02)


def _read_json(path: Path) -> dict:
    try:
        value = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}  # held, but the holder has not written its name yet
    return value if isinstance(value, dict) else {}
