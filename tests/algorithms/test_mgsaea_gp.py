"""MGSAEA-IPC with its default surrogate (the BoTorch GP): end to end on MW3 and via the CLI.

GP fits dominate the run time (minutes on the shared 2-core machine), so these are slow
studies: ``make test-slow`` or ``pytest -m slow tests/algorithms/test_mgsaea_gp.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tmopt.algorithms.mgsaea import MGSAEAIPC
from tmopt.problems.suites import PymooBenchmark
from tmopt.run.runner import run_optimisation

pytest.importorskip("tmopt.surrogates.gp")
REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow


def test_ipc_with_default_gp_on_mw3_n10_budget_150_reaches_feasibility():
    alg = MGSAEAIPC()  # surrogate=None -> GPSurrogate
    res = run_optimisation(PymooBenchmark("mw3", n_var=10), alg, budget=150, seed=0,
                           progress=False, plots=False)
    assert len(res.archive) == 150
    assert res.metrics["feasible_ratio"] > 0
    assert len(np.unique(res.archive.X, axis=0)) == 150
    assert res.metrics["chosen"]["feasible"]


@pytest.mark.skipif(not (REPO / "tmopt" / "conf" / "surrogate" / "gp.yaml").exists(),
                    reason="tmopt/conf/surrogate/gp.yaml is not there yet")
def test_cli_runs_mgsaea_ipc_with_the_gp(tmp_path):
    out = subprocess.run(
        [sys.executable, "-m", "tmopt", "problem=mw3", "problem.n_var=6", "algorithm=mgsaea_ipc",
         "surrogate=gp", "budget=75", "algorithm.wmax=5", f"hydra.run.dir={tmp_path}"],
        cwd=REPO, env={**os.environ, "PYTHONUNBUFFERED": "1"}, capture_output=True,
        text=True, timeout=1200)
    assert out.returncode == 0, out.stderr[-2000:]
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["n_evals"] == 75 and metrics["algorithm"] == "mgsaea_ipc"
    assert "granularity=key" in (tmp_path / "tmopt.log").read_text()
