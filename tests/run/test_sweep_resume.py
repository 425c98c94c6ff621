"""Sweep-level resume: a re-run sweep launches only its unfinished runs (tmopt/run/sweep_resume.py).

Run folders are made by real runs (MW1, tiny budgets) and then put in each state a killed
sweep leaves behind; the classification, the summary line and the sweep command through
Hydra's basic launcher are checked on them. tests/run/test_robustness.py kills a sweep for
real, tests/run/test_sweeps.py re-runs one through joblib, `pytest -m slow
tests/test_slurm.py` through SLURM.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tmopt.algorithms.nsga2 import NSGA2
from tmopt.evaluation.archive import read_archive
from tmopt.problems.suites import PymooBenchmark
from tmopt.run.run_lock import LOCK_FILE, RunFolderBusy, hold_run_lock, lock_holder
from tmopt.run.runner import run_optimisation
from tmopt.run.sweep_resume import JobTarget, RunPlan, classify_run, plan_sweep, summary_line

REPO = Path(__file__).resolve().parents[1]


def _complete_run(outdir: Path, config_hash: str = "h1", budget: int = 20) -> None:
    run_optimisation(PymooBenchmark("mw1", n_var=4), NSGA2(pop_size=10), budget=budget, seed=0,
                     outdir=outdir, config_hash=config_hash, progress=False, plots=False)


def _state(outdir: Path, config_hash: str = "h1", resume: bool = True) -> tuple[str, int]:
    state, archived, _ = classify_run(JobTarget(outdir, config_hash, resume))
    return state, archived


def test_each_folder_state_is_classified(tmp_path):
    done, killed, fresh = tmp_path / "done", tmp_path / "killed", tmp_path / "fresh"
    _complete_run(done)
    _complete_run(killed)
    (killed / "metrics.json").unlink()  # what a run killed after its last batch leaves
    fresh.mkdir()  # Hydra made the folder, the run never wrote

    assert _state(done) == ("skipped", 0)
    assert _state(killed) == ("resumed", 20)
    assert _state(fresh) == ("started", 0)
    assert _state(tmp_path / "absent") == ("started", 0)
    # what the run would refuse is launched so that it says why (failure.json)
    assert _state(done, resume=False) == ("blocked", 0)
    assert _state(killed, config_hash="h2") == ("blocked", 20)
    assert _state(done, config_hash="h2") == ("blocked", 20)  # complete, but not this config
    (fresh / "archive.h5").write_bytes(b"not an HDF5 file")
    state, _, why = classify_run(JobTarget(fresh, "h1", True))
    # the run keeps it aside (archive.h5.unreadable) and starts over (tests/run/test_integrity.py)
    assert state == "started" and why.startswith("unreadable archive")


def test_a_run_locked_by_a_live_process_is_running_and_not_launched(tmp_path):
    _complete_run(tmp_path)
    (tmp_path / "metrics.json").unlink()
    with hold_run_lock(tmp_path):
        state, archived, why = classify_run(JobTarget(tmp_path, "h1", True))
        assert (state, archived) == ("running", 0)
        assert f"in use by process {os.getpid()}" in why
        plan = plan_sweep([["seed=0"]], lambda ov: JobTarget(tmp_path, "h1", True))
        assert plan == [RunPlan(("seed=0",), tmp_path, "running", 0, why)]
        assert not plan[0].launch
    assert _state(tmp_path) == ("resumed", 20)  # released with the block


def test_summary_line_counts_every_state():
    def plan(state: str, archived: int = 0) -> RunPlan:
        return RunPlan((), Path("."), state, archived)

    plans = [plan("skipped"), plan("skipped"), plan("resumed", 40), plan("resumed", 7),
             plan("started"), plan("running"), plan("blocked")]
    assert [p.launch for p in plans] == [False, False, True, True, True, False, True]
    assert summary_line(plans) == (
        "tmopt sweep: 7 runs: 2 skipped (complete), 1 running elsewhere (not launched), "
        "2 resumed (47 archived evaluations), 1 blocked (launched to report why), "
        "1 started; launching 4")
    # the usual case names only the three kinds
    assert summary_line([plan("skipped"), plan("started")]) == (
        "tmopt sweep: 2 runs: 1 skipped (complete), 0 resumed (0 archived evaluations), "
        "1 started; launching 1")


def test_a_second_process_cannot_take_a_held_lock_and_a_killed_holder_frees_it(tmp_path):
    with hold_run_lock(tmp_path):
        with pytest.raises(RunFolderBusy, match=f"in use by process {os.getpid()} on "):
            with hold_run_lock(tmp_path):
                pass
    assert lock_holder(tmp_path) is None
    # the kernel drops the lock of a SIGKILLed holder: nothing stale is left behind
    code = ("import sys, time; from tmopt.run.run_lock import hold_run_lock\n"
            "with hold_run_lock(sys.argv[1]):\n    print('held', flush=True); time.sleep(600)")
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        assert lock_holder(tmp_path)["pid"] == proc.pid
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    assert lock_holder(tmp_path) is None
    assert (tmp_path / LOCK_FILE).exists()  # the file stays; only a held lock counts


# ---- the sweep command ------------------------------------------------------------------
RUN = ["problem=mw1", "problem.n_var=4", "algorithm=nsga2", "algorithm.pop_size=10",
       "budget=30", "progress=false", "plots=false"]


def _tmopt(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "NUMBA_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "tmopt", *args, *RUN], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=600)


def _folder(seed: int) -> str:
    return ",".join(sorted([a for a in RUN if not a.startswith(("progress=", "plots="))]
                           + [f"seed={seed}"]))


def test_a_rerun_sweep_launches_only_what_is_unfinished(tmp_path):
    sweep = ["-m", "seed=0,1,2,3", f"hydra.sweep.dir={tmp_path}"]
    first = _tmopt(*sweep)
    assert first.returncode == 0, first.stderr[-2000:]
    assert ("tmopt sweep: 4 runs: 0 skipped (complete), 0 resumed (0 archived evaluations), "
            "4 started; launching 4") in first.stdout
    runs = [tmp_path / _folder(seed) for seed in range(4)]
    done_log = (runs[0] / "tmopt.log").read_text()
    (runs[1] / "metrics.json").unlink()  # killed after its last batch
    archive1 = read_archive(runs[1] / "archive.h5")
    shutil.rmtree(runs[2])  # killed before Hydra made its folder
    (runs[3] / "metrics.json").unlink()  # still running in another process (lock below)
    log3 = (runs[3] / "tmopt.log").read_text()

    with hold_run_lock(runs[3]):
        second = _tmopt(*sweep)
        # and a run started by hand on the folder in use is refused, its folder untouched
        by_hand = _tmopt(f"hydra.run.dir='{runs[3]}'", "seed=3")
    assert second.returncode == 0, second.stderr[-2000:]
    assert ("tmopt sweep: 4 runs: 1 skipped (complete), 1 running elsewhere (not launched), "
            "1 resumed (30 archived evaluations), 1 started; launching 2") in second.stdout
    assert (runs[0] / "tmopt.log").read_text() == done_log  # not launched
    assert "resuming from 30 archived evaluations" in (runs[1] / "tmopt.log").read_text()
    after = read_archive(runs[1] / "archive.h5")
    assert after.X.tobytes() == archive1.X.tobytes()  # nothing evaluated again
    for run in runs[:3]:
        assert json.loads((run / "metrics.json").read_text())["status"] == "complete"
    assert by_hand.returncode == 1
    assert f"not run: run folder {runs[3]} is in use by process {os.getpid()}" in (
        by_hand.stdout + by_hand.stderr)
    assert not (runs[3] / "metrics.json").exists() and not (runs[3] / "failure.json").exists()
    assert (runs[3] / "tmopt.log").read_text().startswith(log3)

    third = _tmopt(*sweep)  # the lock is gone: the last run resumes, nothing else runs
    assert ("tmopt sweep: 4 runs: 3 skipped (complete), 1 resumed (30 archived evaluations), "
            "0 started; launching 1") in third.stdout
    assert json.loads((runs[3] / "metrics.json").read_text())["status"] == "complete"
