"""The Hydra entry point: help, a full run's files, resume/skip, one-line config errors."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from tmopt.run.cli import available, preflight
from tmopt.run.config import ConfigError

REPO = Path(__file__).resolve().parents[2]


def tmopt(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.run([sys.executable, "-m", "tmopt", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_help_lists_config_groups():
    out = tmopt("--help")
    assert out.returncode == 0
    for group in ("problem:", "algorithm:", "experiment:"):
        assert group in out.stdout
    assert "mw3" in out.stdout and "nsga2" in out.stdout


def test_run_writes_every_output_file_and_a_rerun_skips(tmp_path):
    run_dir = tmp_path / "run"
    args = ["problem=mw1", "algorithm=nsga2", "budget=60", "algorithm.pop_size=20",
            f"hydra.run.dir={run_dir}"]
    out = tmopt(*args)
    assert out.returncode == 0, out.stderr
    for name in ("config.yaml", "archive.h5", "archive.csv", "pareto.csv", "best.json",
                 "metrics.json", "pareto.png", "convergence.png"):
        assert (run_dir / name).is_file(), name
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["n_evals"] == 60 and metrics["budget"] == 60
    assert metrics["status"] == "complete"
    _assert_versions_recorded(metrics["versions"])
    log = (run_dir / "tmopt.log").read_text()
    assert "evals 60/60" in log  # one progress line per generation
    assert log.count("| evals ") == 3
    assert "## mw1 / nsga2 / seed 0" in out.stdout  # the result table

    again = tmopt(*args)
    assert again.returncode == 0
    assert "already complete" in (run_dir / "tmopt.log").read_text()


def _assert_versions_recorded(versions: dict) -> None:
    """The recorded versions are those the libraries report of themselves."""
    import botorch
    import gpytorch
    import numpy
    import scipy
    import torch

    assert versions["python"] == platform.python_version()
    for module in (torch, botorch, gpytorch, numpy, scipy):
        assert versions[module.__name__] == module.__version__, module.__name__
    from pymoo.version import __version__ as pymoo_version
    assert versions["pymoo"] == pymoo_version
    assert {"numba", "hydra-core", "h5py"} <= versions.keys()


@pytest.mark.parametrize("args, expected", [
    (["problem=nope"], "unknown problem 'nope'; choose one of: "),
    (["algorithm=nope"], "unknown algorithm 'nope'; choose one of: "),
    (["budget=abc"], "budget=abc"),
    (["budget=0"], "budget=0 is invalid"),
    (["seed=-1"], "seed=-1 is invalid"),
    (["problem.bogus=1"], "problem.bogus"),
    (["algorithm.pop_size=1"], "pop_size must be an integer >= 2"),
    (["algorithm.pop_size=abc"], "algorithm.pop_size='abc' has the wrong type; expected int"),
    (["budget=50"], "budget=50 is smaller than its initial sample"),
    (["algorithm=nsga2,nope"], "unknown algorithm 'nope'"),
    (["seed=0,1", "algorithm.pop_size=10,1"], "pop_size must be an integer >= 2"),
    (["problem=mw1", "problem.name=not_a_problem"], "'not_a_problem' is not a suite problem"),
])
def test_preflight_names_the_bad_value(args, expected):
    with pytest.raises(ConfigError) as err:
        preflight(args)
    message = str(err.value)
    assert expected in message
    assert "\n" not in message


def test_preflight_checks_each_sweep_value_once():
    n = preflight(["seed=0,1,2", "algorithm=nsga2,nsga3", "budget=200"])
    assert n == 1 + 2 + 1  # base combination, then each other value of a sweep


def test_unknown_group_option_lists_choices():
    with pytest.raises(ConfigError) as err:
        preflight(["problem=nope"])
    for name in available("problem"):
        assert name in str(err.value)


def test_command_line_error_is_one_line_and_exit_2():
    out = tmopt("problem=nope")
    assert out.returncode == 2
    lines = [ln for ln in out.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("tmopt: error: unknown problem 'nope'")
    assert "Traceback" not in out.stderr


def test_output_folder_that_cannot_be_created_is_one_clear_error(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    out = tmopt("problem=mw1", "budget=100", f"hydra.run.dir={blocker}/run")
    assert out.returncode == 2
    assert out.stderr.strip() == (f"tmopt: error: output folder {blocker}/run cannot be "
                                  f"created: {blocker} is a file")


def test_read_only_output_folder_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if os.access(locked, os.W_OK):
            pytest.skip("running as a user who can write anywhere (root)")
        with pytest.raises(ConfigError, match="not writable"):
            preflight([f"hydra.run.dir={locked}/run"])
    finally:
        locked.chmod(0o700)


def test_keys_of_a_swept_group_are_forced_so_hydra_accepts_them():
    from tmopt.run.cli import force_swept_group_keys

    args = ["-m", "algorithm=mgsaea,mgsaea_ipc", "algorithm.n_init=45", "budget=60", "seed=1"]
    assert force_swept_group_keys(args) == [
        "-m", "algorithm=mgsaea,mgsaea_ipc", "++algorithm.n_init=45", "budget=60", "seed=1"]
    single = ["algorithm=mgsaea", "algorithm.n_init=45"]
    assert force_swept_group_keys(single) == single  # not a sweep: Hydra takes it as is
    assert preflight(force_swept_group_keys(args + ["problem=mw1"])) == 2


def test_a_forced_key_is_still_refused_by_an_option_without_it():
    from tmopt.run.cli import force_swept_group_keys

    args = ["-m", "algorithm=mgsaea,nsga2", "algorithm.n_init=45", "problem=mw1"]
    with pytest.raises(ConfigError, match="algorithm=nsga2: unknown key algorithm.n_init"):
        preflight(force_swept_group_keys(args))


def test_run_folders_do_not_depend_on_override_prefixes():
    from tmopt.run.config import run_folder_name

    assert run_folder_name("++algorithm.n_init=45,algorithm=mgsaea,budget=1e+5,~plots") == \
        "algorithm.n_init=45,algorithm=mgsaea,budget=1e+5,plots"
