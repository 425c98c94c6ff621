"""The two paper sweeps through the CLI with the presets and launchers, then collect.

Real runs (real stiffness simulations and MW1) with tiny budgets: the Table 3 command
(algorithms x seeds) through Hydra's basic launcher and the scheme x k command through
the joblib launcher preset, a run made to fail (a corrupt archive where the run will
write) and one left incomplete (its metrics.json removed, which is what a run killed
before its end leaves on disk; tests/run/test_robustness.py kills runs for real). The same
Table 3 command is then re-run through joblib: finished runs are skipped and the
incomplete one resumes, so run folders do not depend on the launcher.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tmopt.reporting.collect import collect
from tmopt.reporting.runs import discover_runs
from tmopt.run.cli import available, preflight

REPO = Path(__file__).resolve().parents[2]
TINY = ["experiment=quick", "budget=40", "algorithm.pop_size=20", "progress=false",
        "plots=false"]
TABLE3 = ["algorithm=nsga2,nsga3", "problem=stiffness,mw1", "seed=0,1"]
SCHEME_K = ["algorithm=nsga2", "scheme=A,B", "problem.n_freq=1,2"]


def _sweep(args: list[str], sweep_dir: Path, *launcher: str) -> str:
    extra = [f"hydra/launcher={launcher[0]}", *launcher[1:]] if launcher else []
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "NUMBA_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-m", "tmopt", "-m", *TINY, *args, *extra,
                          f"hydra.sweep.dir={sweep_dir}"], cwd=REPO, env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def _folder(*overrides: str) -> str:
    """Hydra's override_dirname: the run's overrides sorted, run-only keys left out."""
    keep = [o for o in (*TINY, *overrides) if not o.startswith(("progress=", "plots="))]
    return ",".join(sorted(keep))


@pytest.mark.parametrize("preset", ["quick", "paper"])
def test_presets_compose_with_every_algorithm(preset):
    for algorithm in available("algorithm"):
        assert preflight([f"experiment={preset}", f"algorithm={algorithm}"]) == 1


def test_quick_preset_admits_the_whole_scheme_by_k_sweep_with_its_default_algorithm():
    # MGSAEA-IPC's initial sample is 11 D - 1: 329 at D = 30 (scheme B/C, k = 5) <= 350.
    for scheme in "ABC":
        for k in range(1, 6):
            assert preflight(["experiment=quick", f"scheme={scheme}",
                              f"problem.n_freq={k}"]) == 1


def test_paper_preset_gives_the_mgsaea_family_697_real_evaluations_at_18_variables():
    from hydra import compose

    from tmopt.run.build import build
    from tmopt.run.cli import _hydra_context

    with _hydra_context():
        for algorithm in ("mgsaea", "mgsaea_ipc", "mgsaea_star"):
            cfg = compose("config", ["experiment=paper", f"algorithm={algorithm}"])
            problem, algo = build(cfg)
            assert problem.n_var == 18 and cfg.budget == 10_000
            # 11 D - 1 initial designs, then 100 iterations of mu = 5 (stops by itself)
            assert algo.initial_sample_size(problem) + algo.max_iter * algo.mu == 697
            assert (algo.pop_size, algo.gap, algo.sigma) == (100, 20, 1e-3)


# a 35 s study (CI's 15 min; `make test-slow`): test_sweep_resume keeps a sweep end to end
@pytest.mark.slow
def test_both_sweeps_through_basic_and_joblib_then_collect_lists_failed_and_incomplete(
        tmp_path):
    sweep = tmp_path / "sweep"
    failed = sweep / _folder("algorithm=nsga3", "problem=mw1", "seed=1")
    failed.mkdir(parents=True)
    (failed / "archive.h5").write_bytes(b"not an HDF5 file")
    _sweep(TABLE3, sweep)  # basic launcher
    _sweep(SCHEME_K, sweep, "local_parallel")  # joblib launcher, 2 processes
    # an archive that cannot be read is kept aside and the run starts over (issue 20)
    assert (failed / "archive.h5.unreadable").read_bytes() == b"not an HDF5 file"
    assert json.loads((failed / "metrics.json").read_text())["status"] == "complete"
    # for collect: the folder of a run that stopped on an unreadable archive, as round one
    # left it (cli._record_failure writes failure.json; the archive stays unreadable)
    (failed / "metrics.json").unlink()
    (failed / "archive.h5").write_bytes(b"not an HDF5 file")
    (failed / "failure.json").write_text(json.dumps({"error": "ArchiveError",
                                                     "message": "archive.h5: unreadable"}))
    unfinished = sweep / _folder("algorithm=nsga2", "problem=mw1", "seed=1")
    (unfinished / "metrics.json").unlink()

    out = tmp_path / "collected"
    names = {p.name for p in collect(sweep, out, at=[20, 40])}
    assert names >= {"summary.md", "runs.csv", "status.md", "status.csv", "table3.md",
                     "table3.csv", "table3_vs_paper.md", "configurations.md",
                     "configurations.csv", "fig8.png", "fig9.png", "fig10.png", "fig10.csv",
                     "fig10.md", "benchmarks.md", "benchmarks.csv", "benchmarks_igd.png",
                     "benchmarks_hv.png", "anytime_stiffness.md", "anytime_stiffness.csv",
                     "anytime_stiffness.png", "anytime_benchmarks.md",
                     "anytime_benchmarks.png"}
    status = (out / "status.md").read_text()
    assert f"| {failed.name} | failed | 1 | ?/40 | ArchiveError: " in status
    assert f"| {unfinished.name} | incomplete | 1 | 40/40 |" in status
    assert "reproduces the run's stored numbers exactly" in (out / "fig10.md").read_text()
    with open(out / "table3.csv") as fh:
        table3 = {r["algorithm"]: r for r in csv.DictReader(fh)}
    assert table3["nsga2"]["n_complete"] == "2" and table3["nsga3"]["n_complete"] == "2"
    with open(out / "configurations.csv") as fh:
        configs = {(r["scheme"], r["problem.n_freq"]) for r in csv.DictReader(fh)}
    assert configs == {("A", "1"), ("A", "2"), ("B", "1"), ("B", "2"), ("B", "3")}
    with open(out / "benchmarks.csv") as fh:
        bench = {r["algorithm"]: r for r in csv.DictReader(fh)}
    assert (bench["nsga2"]["n_runs"], bench["nsga2"]["n_complete"]) == ("2", "1")
    assert (bench["nsga3"]["n_runs"], bench["nsga3"]["n_complete"]) == ("2", "1")
    # anytime view: at the full budget the archive's choice is the final Table 3 choice
    # (re-simulated there, read from the archive here); the unfinished run counts as far
    # as it got (all 40), the failed one (no readable archive) reached nothing
    with open(out / "anytime_stiffness.csv") as fh:
        anytime = {(r["algorithm"], r["scheme"], r["problem.n_freq"], r["evaluations"]): r
                   for r in csv.DictReader(fh)}
    for algo in ("nsga2", "nsga3"):
        at40 = anytime[(algo, "B", "3", "40")]
        assert at40["n_complete"] == "2"
        assert float(at40["M_TM1_mean"]) == pytest.approx(
            float(table3[algo]["M_TM1_mean"]), rel=1e-12)
        # the headline is held-out there too: the same design on the same held-out seeds
        assert float(at40["heldout_M_mean"]) == pytest.approx(
            float(table3[algo]["heldout_M_mean"]), rel=1e-12)
    with open(out / "anytime_benchmarks.csv") as fh:
        early = {(r["algorithm"], r["evaluations"]): r for r in csv.DictReader(fh)}
    assert (early[("nsga2", "40")]["n_runs"], early[("nsga2", "40")]["n_complete"]) == (
        "2", "2")
    assert (early[("nsga3", "20")]["n_runs"], early[("nsga3", "20")]["n_complete"]) == (
        "2", "1")

    # the same command through the other launcher (one worker: only resume/skip is checked);
    # the finished runs are not even launched (tmopt/run/sweep_resume.py); the failed one
    # (unreadable archive) starts over, its archive kept aside
    done = sweep / _folder("algorithm=nsga3", "problem=stiffness", "seed=0")
    done_log = (done / "tmopt.log").read_text()
    out = _sweep(TABLE3, sweep, "local_parallel", "hydra.launcher.n_jobs=1")
    assert ("tmopt sweep: 8 runs: 6 skipped (complete), 1 resumed (40 archived evaluations), "
            "1 started; launching 2") in out
    assert json.loads((failed / "metrics.json").read_text())["status"] == "complete"
    assert "resuming from 40" in (unfinished / "tmopt.log").read_text()
    assert (done / "tmopt.log").read_text() == done_log


@pytest.mark.slow
def test_submitit_local_launcher_writes_the_same_run_folders(tmp_path):
    # Each job is a separate process started by submitit (~30 s each here): slow.
    sweep = tmp_path / "sweep"
    _sweep(["algorithm=nsga2", "seed=0,1"], sweep, "submitit_local",
           "hydra.launcher.timeout_min=10")
    for seed in (0, 1):
        run = sweep / _folder("algorithm=nsga2", f"seed={seed}")
        assert json.loads((run / "metrics.json").read_text())["status"] == "complete"
    assert (sweep / ".submitit").is_dir()  # submitit's own logs, which collect skips
    assert {r.name for r in discover_runs(sweep)} == {
        _folder("algorithm=nsga2", "seed=0"), _folder("algorithm=nsga2", "seed=1")}
    again = _sweep(["algorithm=nsga2", "seed=0,1"], sweep, "submitit_local",
                   "hydra.launcher.timeout_min=10")
    assert ("tmopt sweep: 2 runs: 2 skipped (complete), 0 resumed (0 archived evaluations), "
            "0 started; launching 0") in again


def test_a_sweep_without_a_name_gets_one_from_its_overrides(tmp_path):
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "NUMBA_NUM_THREADS": "1"}
    args = ["problem=mw3", "problem.n_var=4", "algorithm=nsga2", "algorithm.pop_size=10",
            "budget=20", "seed=0,1", "progress=false", "plots=false"]
    out = subprocess.run([sys.executable, "-m", "tmopt", "-m", *args], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    name = "algorithm=nsga2_budget=20_problem=mw3_seed=0+1_algorithm.pop_size=10_problem.n_var=4"
    assert [p.name for p in (tmp_path / "multirun").iterdir()] == [name]
    assert len(list((tmp_path / "multirun" / name).glob("*/metrics.json"))) == 2
