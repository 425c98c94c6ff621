"""The Python API: docs/python-api.md runs as written (at small budgets), tmopt and pymoo
combine both ways, and every way in gives the command line's archive for the same seed."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pymoo.optimize import minimize
from pymoo.problems import get_problem

import tmopt
from tmopt.algorithms import MGSAEAIPC, NSGA2, AlgorithmConfigError
from tmopt.evaluation.archive import read_archive

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "python-api.md"
#: What the documented examples spend, and what the test spends instead; each must occur.
SMALLER = {
    'get_problem("mw3")': 'get_problem("mw3", n_var=4)',
    "MGSAEAIPC()": "MGSAEAIPC(pop_size=10, n_init=20, wmax=3)",
    '("n_evals", 300)': '("n_evals", 40)',
    "budget=300": "budget=40",
    "budget=200": "budget=40",
    "duration=600": "duration=120",
}


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_every_documented_example_runs(tmp_path, monkeypatch, capsys):
    blocks = _blocks()
    assert len(blocks) == 5
    text = "\n".join(blocks)
    for big, small in SMALLER.items():
        assert big in text, f"docs/python-api.md no longer has {big}; update SMALLER"
        blocks = [b.replace(big, small) for b in blocks]
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, str(DOC), "exec"), {"__name__": "__doc_example__"})
    printed = capsys.readouterr().out
    assert "40 real evaluations" in printed and "chosen by Eq. 21" in printed
    assert (tmp_path / "api_run" / "metrics.json").is_file()
    assert (tmp_path / "diagnosis" / "report.md").is_file()
    assert "mismatch detected:" in printed


def test_public_names():
    from tmopt.algorithms import __all__ as names

    for name in ("MGSAEA", "MGSAEAIPC", "MGSAEAStar", "NSGA2", "NSGA3", "CMOEAD", "CTSEA",
                 "SSDE", "CMOES", "QLogNEHVI"):
        assert name in names and callable(getattr(tmopt.algorithms, name))
    assert callable(tmopt.run_optimisation) and callable(tmopt.diagnose)
    assert callable(tmopt.simulate) and callable(tmopt.simulate.summary)  # function + module


def test_minimize_returns_a_pymoo_result_with_archive_and_choice():
    res = minimize(get_problem("mw3", n_var=4), MGSAEAIPC(pop_size=10, n_init=20, wmax=3),
                   ("n_evals", 30), seed=1)
    X = res.archive.get("X")
    assert X.shape == (30, 4)
    chosen = res.chosen
    assert np.array_equal(X[chosen["index"]], chosen["X"])
    # the final set is the feasible non-dominated part of the archive, the choice in it
    assert res.success and np.all(res.CV <= 0)
    assert any(np.array_equal(x, chosen["X"]) for x in res.X)
    assert res.algorithm.n_evals == 30 and res.exec_time > 0


def _cli_archive(tmp_path: Path, algorithm: list[str], budget: int, seed: int) -> np.ndarray:
    out = tmp_path / "cli"
    done = subprocess.run(
        [sys.executable, "-m", "tmopt", "problem=mw3", "problem.n_var=4", *algorithm,
         f"budget={budget}", f"seed={seed}", "progress=false", "plots=false",
         f"hydra.run.dir={out}"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return read_archive(out / "archive.h5").X


@pytest.mark.parametrize("name,make,options", [
    ("nsga2", lambda: NSGA2(pop_size=10), ["algorithm=nsga2", "algorithm.pop_size=10"]),
    ("mgsaea_ipc", lambda: MGSAEAIPC(pop_size=10, n_init=20, wmax=3),
     ["algorithm=mgsaea_ipc", "algorithm.pop_size=10", "algorithm.n_init=20",
      "algorithm.wmax=3"]),
])
def test_both_directions_give_the_command_lines_archive(tmp_path, name, make, options):
    budget, seed = 40, 3
    cli = _cli_archive(tmp_path, options, budget, seed)
    res = minimize(get_problem("mw3", n_var=4), make(), ("n_evals", budget), seed=seed)
    run = tmopt.run_optimisation(get_problem("mw3", n_var=4), make(), budget=budget,
                                 seed=seed, progress=False, plots=False)
    assert cli.shape == (budget, 4)
    assert np.array_equal(res.archive.get("X"), cli)
    assert np.array_equal(run.archive.X, cli)


def test_a_pymoo_algorithm_runs_in_tmopts_runner():
    from pymoo.algorithms.moo.nsga2 import NSGA2 as PymooNSGA2

    run = tmopt.run_optimisation(get_problem("mw3", n_var=4), PymooNSGA2(pop_size=10),
                                 budget=30, seed=0, progress=False, plots=False)
    assert run.metrics["algorithm"] == "nsga2" and len(run.archive) == 30


def test_equality_constraints_use_pymoos_tolerance():
    from pymoo.core.problem import Problem

    from tmopt.problems.pymoo_problem import as_expensive

    class OnLine(Problem):
        def __init__(self):
            super().__init__(n_var=2, n_obj=1, n_eq_constr=1, xl=0.0, xu=1.0)

        def _evaluate(self, X, out, *args, **kwargs):
            out["F"] = X[:, :1]
            out["H"] = X[:, 1:] - 0.5

    wrapped = as_expensive(OnLine())
    G = wrapped.evaluate(np.array([[0.1, 0.5], [0.1, 0.50005], [0.1, 0.6]]),
                         return_values_of=["G"])
    assert wrapped.n_ieq_constr == 1 and wrapped.constraint_names == ["h1"]
    assert (G[:, 0] <= 0).tolist() == [True, True, False]


@pytest.mark.parametrize("termination,message", [
    (("n_gen", 10), "needs a budget of real evaluations"),
    (None, "needs a budget of real evaluations"),
])
def test_minimize_refuses_what_is_not_a_budget(termination, message):
    with pytest.raises(AlgorithmConfigError, match=re.escape(message)):
        minimize(get_problem("mw3", n_var=4), NSGA2(pop_size=10), termination)


def test_minimize_refuses_an_unknown_option():
    with pytest.raises(AlgorithmConfigError, match="option 'save_history' is not supported"):
        minimize(get_problem("mw3", n_var=4), NSGA2(pop_size=10), ("n_evals", 20),
                 save_history=True)
