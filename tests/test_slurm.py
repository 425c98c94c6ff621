"""Sweeps through a real SLURM cluster: submitted, cancelled, timed out, resumed, compared.

Slow (~9 min on 2 cores, plus ~1 min to install the packages the first time) and they need
a SLURM cluster: run as root on a Debian-like machine they bring one up on this machine
(experiments/slurm_local.sh) and take it down again afterwards; where a cluster already
answers (`sinfo`) they use that one and leave it up. One command:

    pytest -m slow tests/test_slurm.py

experiments/slurm_sweep.py says what each check does.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
LOCAL_CLUSTER = REPO / "experiments" / "slurm_local.sh"

pytestmark = pytest.mark.slow


def _cluster_answers() -> bool:
    if shutil.which("sinfo") is None:
        return False
    return subprocess.run(["sinfo", "-h"], capture_output=True).returncode == 0


@pytest.fixture(scope="module")
def slurm_cluster():
    was_up = _cluster_answers()
    if not was_up and os.geteuid() != 0:
        pytest.skip("no SLURM cluster answers and only root can start the local one "
                    "(sudo experiments/slurm_local.sh up)")
    if not was_up:
        up = subprocess.run(["bash", str(LOCAL_CLUSTER), "up"], capture_output=True, text=True,
                            timeout=900)
        assert up.returncode == 0, up.stdout + up.stderr
    yield
    if not was_up:
        subprocess.run(["bash", str(LOCAL_CLUSTER), "down"], capture_output=True, timeout=300)


def _slurm_sweep(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(REPO / "experiments" / "slurm_sweep.sh"), *args],
                          capture_output=True, text=True,
                          env={**os.environ, "PYTHON": sys.executable}, timeout=3600)


def test_a_sweep_through_slurm_resumes_its_cancelled_job_and_equals_the_local_sweep(
        slurm_cluster, tmp_path):
    sweep = _slurm_sweep("--quick", "--out", str(tmp_path))
    report = sweep.stdout + sweep.stderr
    assert sweep.returncode == 0, report
    assert sweep.stdout.strip().splitlines()[-1] == (
        "slurm: jobs=12 completed=12 cancelled_then_resumed=1 identical_to_local=True"), report
    # the re-run launched only the cancelled run, which resumed from its archive
    assert "tmopt sweep: 12 runs: 11 skipped (complete), 1 resumed (" in report
    assert (tmp_path / "slurm_quick" / "collected" / "table3.md").exists()


def test_a_run_past_its_time_limit_is_requeued_and_resumes_to_the_local_result(
        slurm_cluster, tmp_path):
    run = _slurm_sweep("--time-limit", "--out", str(tmp_path))
    report = run.stdout + run.stderr
    assert run.returncode == 0, report
    last = run.stdout.strip().splitlines()[-1]
    assert last.startswith("slurm: time_limit "), report
    fields = dict(kv.split("=") for kv in last.split()[2:])
    assert int(fields["requeued"]) >= 1 and int(fields["resumed_from"]) > 0, report
    assert (fields["completed"], fields["identical_to_local"]) == ("True", "True"), report
