"""What every algorithm must do, as helpers its test module calls with its own settings."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from tmopt.evaluation.evaluator import Evaluator
from tmopt.run.cli import option_config
from tmopt.run.config import check_node
from tmopt.run.runner import run_optimisation

REPO = Path(__file__).resolve().parents[2]


def run(alg, problem, budget, seed=0):
    """A run in memory (no folder, no progress, no plots)."""
    return run_optimisation(problem, alg, budget=budget, seed=seed, progress=False, plots=False)


def drive_to_budget(alg, problem, budget: int, seed: int = 0) -> Evaluator:
    """ask/tell until the budget is spent, checking every proposal's shape and bounds."""
    alg.setup(problem, budget=budget, seed=seed)
    ev = Evaluator(problem, budget)
    while ev.remaining and alg.has_next():
        X = alg.ask()
        assert X.shape[1] == problem.n_var
        assert np.all((X >= problem.xl) & (X <= problem.xu))
        alg.tell(ev.evaluate(X[: ev.remaining]))
    assert alg.n_evals == len(ev.archive) == budget
    return ev


def assert_seed_decides_the_archive(make, problem, budget: int) -> None:
    """The same seed gives the same archive, another seed another one."""
    a, b, c = (run(make(), problem, budget, seed=s).archive for s in (1, 1, 2))
    assert np.array_equal(a.X, b.X) and np.array_equal(a.F, b.F, equal_nan=True)
    assert not np.array_equal(a.X, c.X)


def algorithm_from_yaml(name: str, **extra):
    """The algorithm its ``tmopt/conf/algorithm/<name>.yaml`` builds (keys checked against
    the constructor's signature), with ``extra`` keyword arguments."""
    node = option_config("algorithm", name)
    cls = check_node("algorithm", node, name)
    kwargs = {k: v for k, v in OmegaConf.to_container(node).items() if not k.startswith("_")}
    alg = cls(**kwargs, **extra)
    assert alg.name == name
    return alg


def cli_metrics(run_dir: Path, *overrides: str) -> dict:
    """``python -m tmopt <overrides>`` into ``run_dir``; its metrics.json."""
    out = subprocess.run([sys.executable, "-m", "tmopt", *overrides, "plots=false",
                          f"hydra.run.dir={run_dir}"], cwd=REPO, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads((run_dir / "metrics.json").read_text())
