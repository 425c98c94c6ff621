"""Run-folder locks (issue 20 part 1): one process per run folder, also without flock.

Both paths are tested: the kernel's flock (local disks) and the O_EXCL lease with a
heartbeat that guards a folder where flock is missing (NFS without lock support) or not
shared between hosts (Lustre's localflock), including the takeover of a dead holder's lease.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import tmopt.run.run_lock as run_lock
from tmopt.evaluation.archive import read_archive
from tmopt.run.run_lock import LEASE_FILE, RunFolderBusy, hold_run_lock, lock_holder

REPO = Path(__file__).resolve().parents[2]
HOLD = ("import sys, time; from tmopt.run.run_lock import hold_run_lock\n"
        "with hold_run_lock(sys.argv[1]):\n    print('held', flush=True); time.sleep(600)")


@pytest.fixture
def no_flock(monkeypatch):
    """A file system without flock (NFS mounted without lock support): ENOLCK."""
    def flock(fd, op):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(run_lock.fcntl, "flock", flock)


def _write_lease(folder: Path, age_s: float = 0.0, **holder) -> Path:
    lease = folder / LEASE_FILE
    lease.write_text(json.dumps({"host": socket.gethostname(), "pid": os.getpid(),
                                 "slurm_job": None, "since": "2026-01-01T00:00:00",
                                 "token": "t0", **holder}))
    then = time.time() - age_s
    os.utime(lease, (then, then))
    return lease


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# ---- flock path ----------------------------------------------------------------------------
def test_a_second_holder_is_refused_naming_pid_host_and_start_time(tmp_path):
    with hold_run_lock(tmp_path):
        with pytest.raises(RunFolderBusy) as err:
            with hold_run_lock(tmp_path):
                pass
    message = str(err.value)
    assert "\n" not in message
    assert f"process {os.getpid()} on {socket.gethostname()} (since " in message
    assert lock_holder(tmp_path) is None
    assert not (tmp_path / LEASE_FILE).exists()  # released with the block


def test_a_sigkilled_holder_leaves_a_lease_that_the_next_run_takes_over(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path)], stdout=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        assert lock_holder(tmp_path)["pid"] == proc.pid
        with pytest.raises(RunFolderBusy, match=f"process {proc.pid} on "):
            with hold_run_lock(tmp_path):
                pass
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    assert (tmp_path / LEASE_FILE).exists()  # SIGKILL: nothing released it
    assert lock_holder(tmp_path) is None  # but it is known to be stale
    with hold_run_lock(tmp_path):
        assert lock_holder(tmp_path)["pid"] == os.getpid()


# ---- lease path: no flock (or a flock that other hosts do not see) ---------------------------
def test_without_flock_the_lease_still_refuses_a_second_holder(tmp_path, no_flock):
    with hold_run_lock(tmp_path):
        assert lock_holder(tmp_path)["pid"] == os.getpid()
        with pytest.raises(RunFolderBusy, match=f"process {os.getpid()} on "):
            with hold_run_lock(tmp_path):
                pass
    assert lock_holder(tmp_path) is None


def test_without_flock_the_lease_of_a_dead_process_on_this_host_is_taken_over(tmp_path,
                                                                           no_flock, caplog):
    pid = _dead_pid()
    _write_lease(tmp_path, pid=pid)
    assert lock_holder(tmp_path) is None
    with hold_run_lock(tmp_path):
        assert lock_holder(tmp_path)["pid"] == os.getpid()
    assert f"process {pid} is gone" in caplog.text


@pytest.mark.parametrize("flock_works_here", [True, False])
def test_a_live_holder_on_another_host_is_refused_until_its_heartbeat_is_stale(
        tmp_path, monkeypatch, flock_works_here):
    """Another host's holder is invisible to this host's flock (Lustre localflock) or there
    is no flock at all: the lease decides, by its heartbeat."""
    if not flock_works_here:
        monkeypatch.setattr(run_lock.fcntl, "flock",
                            lambda fd, op: (_ for _ in ()).throw(OSError(errno.ENOLCK, "")))
    _write_lease(tmp_path, age_s=5, host="node-17", pid=4242)
    with pytest.raises(RunFolderBusy, match=r"process 4242 on node-17 \(since 2026-01-01"):
        with hold_run_lock(tmp_path):
            pass
    assert lock_holder(tmp_path)["host"] == "node-17"
    _write_lease(tmp_path, age_s=run_lock.STALE_AFTER_S + 60, host="node-17", pid=4242)
    assert lock_holder(tmp_path) is None
    with hold_run_lock(tmp_path):
        assert lock_holder(tmp_path)["host"] == socket.gethostname()


def test_a_requeued_slurm_job_takes_over_its_own_lease_from_another_node(tmp_path, no_flock,
                                                                         monkeypatch):
    _write_lease(tmp_path, age_s=5, host="node-17", pid=4242, slurm_job="991_3")
    monkeypatch.setenv("SLURM_ARRAY_JOB_ID", "991")
    monkeypatch.setenv("SLURM_ARRAY_TASK_ID", "3")
    with hold_run_lock(tmp_path):
        assert lock_holder(tmp_path)["slurm_job"] == "991_3"
    monkeypatch.setenv("SLURM_ARRAY_TASK_ID", "4")  # another job: refused
    _write_lease(tmp_path, age_s=5, host="node-17", pid=4242, slurm_job="991_3")
    with pytest.raises(RunFolderBusy, match="SLURM job 991_3"):
        with hold_run_lock(tmp_path):
            pass


def test_the_heartbeat_keeps_a_held_lease_fresh(tmp_path, no_flock, monkeypatch):
    monkeypatch.setattr(run_lock, "HEARTBEAT_S", 0.05)
    with hold_run_lock(tmp_path):
        lease = tmp_path / LEASE_FILE
        os.utime(lease, (0, 0))  # as old as can be
        deadline = time.monotonic() + 60
        while lease.stat().st_mtime == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert time.time() - lease.stat().st_mtime < run_lock.STALE_AFTER_S


def test_a_lease_replaced_between_judgement_and_removal_is_not_stolen(tmp_path):
    stale = {"token": "old"}
    _write_lease(tmp_path, token="fresh")  # what a faster process put there meanwhile
    assert not run_lock._remove_stale(tmp_path / LEASE_FILE, stale)
    assert json.loads((tmp_path / LEASE_FILE).read_text())["token"] == "fresh"
    assert sorted(p.name for p in tmp_path.iterdir()) == [LEASE_FILE]


# ---- whole runs ------------------------------------------------------------------------------
RUN = ["problem=mw1", "problem.n_var=4", "algorithm=nsga2", "algorithm.pop_size=10",
       "budget=200", "progress=false", "plots=false"]


def _start(folder: Path, seed: int) -> subprocess.Popen:
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-m", "tmopt", *RUN, f"seed={seed}",
                             f"hydra.run.dir={folder}"], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("seeds", [(3, 3), (3, 4)], ids=["identical", "seeds 3 and 4"])
def test_two_runs_started_together_into_one_folder_run_once_and_lose_nothing(tmp_path, seeds):
    """Started at the same moment: one runs, the other refuses in one line naming it (or,
    if it comes after the first finished, skips it or refuses another configuration's
    folder); the budget is evaluated once and the folder holds one complete result."""
    folder = tmp_path / "run"
    procs = [_start(folder, s) for s in seeds]
    outs = [p.communicate(timeout=600) for p in procs]
    codes = [p.returncode for p in procs]
    assert 0 in codes, outs
    winner = codes.index(0)
    loser = "".join(outs[1 - winner])
    loser_err = loser.strip().splitlines()
    if codes[1 - winner] != 0:  # refused: one line, no traceback
        assert codes[1 - winner] in (1, 2), outs
        assert len(loser_err) == 1 and "Traceback" not in loser, loser_err
        assert ("is in use by process" in loser_err[0] and "since" in loser_err[0]) \
            or "not this run's" in loser_err[0], loser_err  # came once the archive was there
    data = read_archive(folder / "archive.h5")
    assert len(data) == 200  # the budget, once
    metrics = json.loads((folder / "metrics.json").read_text())
    assert metrics["status"] == "complete" and metrics["n_evals"] == 200
    assert metrics["seed"] == seeds[winner]
    assert f"seed: {seeds[winner]}" in (folder / "config.yaml").read_text()
    # the refused seed's run is refused again rather than overwriting the winner's
    if seeds[0] != seeds[1]:
        again = _start(folder, seeds[1 - winner])
        _, err = again.communicate(timeout=600)
        assert again.returncode == 2 and "holds a finished run" in err
        assert json.loads((folder / "metrics.json").read_text()) == metrics
