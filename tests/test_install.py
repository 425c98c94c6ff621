"""tmopt installed from its wheel (not editable), run from a folder outside the repository.

The wheel is built from a copy of the source and installed into a fresh virtual
environment with ``--no-deps``; that environment sees the dependencies of the one running
the tests through a ``.pth`` line (so CI does not download torch a second time), but
tmopt itself, its configuration (``tmopt/conf``, package data read as ``pkg://tmopt.conf``)
and the sweeper plugin (``hydra_plugins/tmopt_sweeper``) come from the wheel only.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHIPPED = ("pyproject.toml", "README.md", "tmopt", "hydra_plugins")


def _run(cmd: list[str], cwd: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=900,
                          env={**os.environ, "PYTHONUNBUFFERED": "1", **env})


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict:
    """Build the wheel, install it into a fresh venv; return its paths."""
    root = tmp_path_factory.mktemp("wheel")
    src = root / "src"
    src.mkdir()
    for name in SHIPPED:
        copy = shutil.copytree if (REPO / name).is_dir() else shutil.copy2
        copy(REPO / name, src / name, **({"ignore": shutil.ignore_patterns(
            "__pycache__", "*.pyc", "*.egg-info")} if copy is shutil.copytree else {}))
    built = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                  "--no-index", "-q", "-w", str(root / "dist"), str(src)], cwd=root)
    assert built.returncode == 0, built.stderr
    wheel = next((root / "dist").glob("tmopt-*.whl"))
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = _run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                cwd=root).stdout.strip()
    ours = {sysconfig.get_paths()[k] for k in ("purelib", "platlib")}
    Path(site, "project_environment.pth").write_text("\n".join(sorted(ours)) + "\n")
    done = _run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index",
                 str(wheel)], cwd=root)
    assert done.returncode == 0, done.stderr
    work = root / "work"  # not the repository: nothing can come from the source tree
    work.mkdir()
    return {"wheel": wheel, "python": python, "bin": venv / "bin", "work": work,
            "site": Path(site)}


def test_the_wheel_holds_every_config_and_the_sweeper(installed):
    names = set(zipfile.ZipFile(installed["wheel"]).namelist())
    configs = {f"tmopt/conf/{p.relative_to(REPO / 'tmopt' / 'conf').as_posix()}"
               for p in (REPO / "tmopt" / "conf").rglob("*.yaml")}
    assert len(configs) > 40 and configs <= names, sorted(configs - names)
    assert "hydra_plugins/tmopt_sweeper/tmopt_sweeper.py" in names


def test_installed_tmopt_runs_a_sweep_collects_and_simulates_outside_the_repo(installed):
    work, python, bin_ = installed["work"], str(installed["python"]), installed["bin"]
    where = _run([python, "-c", "import tmopt, tmopt.conf; print(tmopt.conf.__file__)"],
                 cwd=work)
    assert Path(where.stdout.strip()).is_relative_to(installed["site"]), where

    sweep = _run([str(bin_ / "tmopt"), "-m", "problem=mw3", "problem.n_var=4",
                  "algorithm=nsga2", "algorithm.pop_size=10", "budget=20", "seed=0,1",
                  "progress=false", "name=wheel"], cwd=work)
    assert sweep.returncode == 0, sweep.stderr
    assert "tmopt sweep: 2 runs" in sweep.stdout  # the sweeper plugin, from the wheel
    runs = sorted((work / "multirun" / "wheel").glob("*/metrics.json"))
    assert [json.loads(p.read_text())["status"] for p in runs] == ["complete"] * 2

    collect = _run([python, "-m", "tmopt.collect", "multirun/wheel"], cwd=work)
    assert collect.returncode == 0, collect.stderr
    collected = work / "multirun" / "wheel" / "collected"
    assert (collected / "runs.csv").is_file() and (collected / "benchmarks_igd.png").is_file()

    # numba's cache of a fresh install is empty and compiling costs a minute; what is
    # tested here is the installed command, the compiled kernels are tested elsewhere
    sim = _run([python, "-m", "tmopt.simulate", "--duration", "60", "--out", "sim/x.h5"],
               cwd=work, NUMBA_DISABLE_JIT="1")
    assert sim.returncode == 0, sim.stderr
    assert (work / "sim" / "x.h5").is_file() and (work / "sim" / "x.png").is_file()


def test_a_users_config_dir_adds_options_and_keeps_one_line_errors(installed):
    work, tmopt = installed["work"], str(installed["bin"] / "tmopt")
    mine = work / "my_conf" / "problem"
    mine.mkdir(parents=True)
    (mine / "my_mw.yaml").write_text(
        "defaults:\n  - /constructor/tmopt.problems.suites.PymooBenchmark@_here_\n"
        "  - _self_\nname: mw1\nn_var: 5\n")
    ok = _run([tmopt, "--config-dir", "my_conf", "problem=my_mw", "algorithm=nsga2",
               "algorithm.pop_size=10", "budget=20", "progress=false", "plots=false"],
              cwd=work)
    assert ok.returncode == 0, ok.stderr
    metrics = json.loads(next((work / "outputs" / "my_mw").rglob("metrics.json")).read_text())
    assert metrics["problem"]["name"] == "mw1" and metrics["problem"]["n_var"] == 5

    for bad, expected in ((["problem=my_mww"], "did you mean 'my_mw'?"),
                          (["problem=my_mw", "problem.n_var=1"], "n_var must be an integer")):
        out = _run([tmopt, "--config-dir", "my_conf", *bad], cwd=work)
        assert out.returncode == 2
        assert expected in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
