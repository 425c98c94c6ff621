"""tmopt.reporting.collect on hand-made run folders: statuses, settings, statistics, tables.

The folders below hold only the files collect reads (metrics.json, failure.json,
config.yaml, .hydra/overrides.yaml + hydra.yaml), with numbers chosen so every expected
value can be worked out by hand. Real sweeps through the CLI are in tests/run/test_sweeps.py.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from tmopt.reporting.collect import collect, main
from tmopt.reporting.runs import deduplicate, discover_runs, setting_keys
from tmopt.reporting.stats import fmt_mean_std, mark, mean_std, rank_sum, signed_rank
from tmopt.reporting.tables import STIFFNESS_METRICS, summarise


def _run(root: Path, name: str, overrides: dict, *, algorithm: str = "nsga2",
         scheme: str = "B", n_freq: int = 3, seed: int = 0, m: float | None = 5.0,
         status: str = "complete", problem: str = "stiffness", igd: float | None = None,
         hv: float | None = None, below_floor: tuple[str, ...] = (),
         stage: int | None = None, feasible_ratio: float | None = None) -> Path:
    """A run folder as the CLI leaves it (only the files collect reads)."""
    path = root / name
    (path / ".hydra").mkdir(parents=True)
    lines = [f"- {k}={v}" for k, v in overrides.items()]
    (path / ".hydra" / "overrides.yaml").write_text("\n".join(lines) + "\n")
    choices = {"problem": problem, "algorithm": algorithm, "scheme": scheme,
               "experiment": None, "surrogate": None, "hydra/launcher": "basic"}
    (path / ".hydra" / "hydra.yaml").write_text(json.dumps(
        {"hydra": {"runtime": {"choices": choices}}}))
    prob = {"_target_": "tmopt.problems.stiffness.StiffnessProblem" if problem == "stiffness"
            else "tmopt.problems.suites.PymooBenchmark", "n_freq": n_freq, "scheme": scheme}
    config = {"problem": prob, "seed": seed, "budget": 100}
    (path / "config.yaml").write_text(json.dumps(config))
    if status == "failed":
        (path / "failure.json").write_text(json.dumps(
            {"error": "ArchiveError", "message": "archive.h5 is not an HDF5 file"}))
    if status == "complete":
        ident = {} if m is None else {
            "M_TM1": m, "convergence_time_TM1": 60.0 * m, "convergence_accuracy_TM1": 1e-10,
            "M_TM1@7e-11": m, "M_TM1@5e-11": m, "final_accuracy_TM1": 1e-11}
        metrics = {"status": "complete", "algorithm": algorithm, "seed": seed, "budget": 100,
                   "n_evals": 100, "wall_time_s": 2.0, "pareto_size": 1,
                   "chosen": {"feasible": True}, "identification": ident,
                   "config_hash": f"{name}-hash", "igd": igd, "hv": hv,
                   "feasible_ratio": feasible_ratio,
                   "algorithm_summary": {} if stage is None else {"stage_reached": stage}}
        if m is not None:  # held-out scores: the search draw's M plus 1 (luck removed)
            stat = lambda v: {"mean": v, "std": 1.0, "median": v}  # noqa: E731
            metrics["heldout"] = {
                "n_seeds": 32, "M": stat(m + 1), "M(7e-11)": stat(m + 1),
                "M(5e-11)": stat(m + 1), "convergence_time": stat(60.0 * m),
                "convergence_accuracy": stat(2e-10), "final_accuracy": stat(1e-10),
                "eq20_share": 1.0}
            metrics["floor"] = {"parameter": "k1xx", "final_accuracy_mean": 7.6e-11,
                                "final_accuracy_rms": 9.5e-11, "M": 3.48,
                                "M_at_convergence_time": 104.0,
                                "below_floor": list(below_floor)}
        (path / "metrics.json").write_text(json.dumps(metrics))
    return path


def test_statuses_and_reasons_of_complete_failed_and_incomplete_runs(tmp_path):
    _run(tmp_path, "a", {"seed": 0})
    _run(tmp_path, "b", {"seed": 1}, seed=1, status="failed")
    _run(tmp_path, "c", {"seed": 2}, seed=2, status="incomplete")
    (tmp_path / "c" / "failure.json").write_text("not json")  # damaged: still incomplete
    runs = {r.name: r for r in discover_runs(tmp_path)}
    assert {k: r.status for k, r in runs.items()} == {
        "a": "complete", "b": "failed", "c": "incomplete"}
    out = tmp_path / "out"
    collect(tmp_path, out, fig10=False)
    status = (out / "status.md").read_text()
    assert "| b | failed | 1 | ?/100 | ArchiveError: archive.h5 is not an HDF5 file |" in status
    assert "| c | incomplete | 2 |" in status and "never evaluated a design" in status
    assert "| a |" not in status  # complete runs are not listed
    table3 = (out / "table3.md").read_text()
    assert "| NSGA-II | 1/3 |" in table3  # 1 of the setting's 3 runs entered the statistics


def test_the_stage_reached_is_a_count_per_setting_and_na_without_stages(tmp_path):
    for seed, stage in enumerate((1, 2, 2)):
        _run(tmp_path, f"m{seed}", {"algorithm": "mgsaea_ipc", "seed": seed},
             algorithm="mgsaea_ipc", seed=seed, stage=stage)
    _run(tmp_path, "n0", {"algorithm": "nsga2", "seed": 0})
    out = tmp_path / "out"
    collect(tmp_path, out, fig10=False)
    table = [line.strip("| ").split(" | ") for line in
             (out / "table3.md").read_text().splitlines() if line.startswith("| ")]
    column = table[0].index("stage two reached")
    cells = {row[0]: row[column] for row in table[2:]}
    assert cells == {"MGSAEA-IPC": "2/3", "NSGA-II": "n/a"}
    with open(out / "table3.csv") as fh:
        rows = {r["algorithm"]: r for r in csv.DictReader(fh)}
    assert float(rows["mgsaea_ipc"]["stage_two_mean"]) == pytest.approx(2 / 3)


def test_a_stale_failure_of_a_rerun_that_finished_does_not_hide_it(tmp_path):
    run = _run(tmp_path, "a", {"seed": 0})
    (run / "failure.json").write_text(json.dumps({"error": "OSError", "message": "full"}))
    assert discover_runs(tmp_path)[0].status == "complete"


def test_settings_are_effective_values_so_two_sweeps_in_one_folder_line_up(tmp_path):
    # A Table 3 sweep (algorithm, seed) and a scheme x k sweep (default algorithm) in one
    # folder: the scheme B / k = 3 run of the second is the same setting as the first's.
    _run(tmp_path, "t3-nsga2", {"algorithm": "nsga2", "seed": 0}, algorithm="nsga2")
    _run(tmp_path, "t3-nsga3", {"algorithm": "nsga3", "seed": 0}, algorithm="nsga3")
    _run(tmp_path, "sk-A1", {"scheme": "A", "problem.n_freq": 1}, scheme="A", n_freq=1)
    _run(tmp_path, "sk-B3", {"scheme": "B", "problem.n_freq": 3}, seed=1)
    runs = discover_runs(tmp_path)
    assert setting_keys(runs) == ["problem", "algorithm", "scheme", "problem.n_freq"]
    by_name = {r.name: r for r in runs}
    assert by_name["sk-B3"].value("algorithm") == "nsga2"  # the default, from Hydra's choices
    assert by_name["t3-nsga2"].value("problem.n_freq") == "3"  # from the resolved config
    out = tmp_path / "out"
    collect(tmp_path, out, fig10=False)
    with open(out / "table3.csv") as fh:
        rows = {r["algorithm"]: r for r in csv.DictReader(fh)}
    assert rows["nsga2"]["n_complete"] == "2" and rows["nsga3"]["n_complete"] == "1"


def test_duplicate_runs_enter_the_statistics_once_and_are_listed(tmp_path):
    _run(tmp_path, "x", {"seed": 0})
    _run(tmp_path, "y", {"seed": 0})
    (tmp_path / "y" / "metrics.json").write_text(
        (tmp_path / "x" / "metrics.json").read_text())  # same config hash
    kept, dropped = deduplicate(discover_runs(tmp_path))
    assert [r.name for r in kept] == ["x"] and [r.name for r in dropped] == ["y"]


def test_rank_sum_p_values_equal_the_exact_distribution():
    # Completely separated samples: two-sided exact p = 2 / C(n+m, n).
    assert rank_sum([1, 2, 3], [4, 5, 6]) == pytest.approx(2 / 20)
    assert rank_sum([1, 2, 3, 4, 5], [6, 7, 8, 9, 10]) == pytest.approx(2 / 252)
    assert math.isnan(rank_sum([1.0], [2.0, 3.0]))  # untestable, not "no difference"
    assert rank_sum([1, 1], [1, 1]) == 1.0
    assert mark([1, 2, 3, 4, 5], [6, 7, 8, 9, 10], 2 / 252) == "+"
    assert mark([6, 7, 8, 9, 10], [1, 2, 3, 4, 5], 2 / 252) == "-"
    assert mark([1, 2, 3], [1, 2, 4], 0.8) == "="


def test_signed_rank_pairs_by_seed_and_equals_the_exact_distribution():
    # Every one of n pairs favours the same side: two-sided exact p = 2 / 2^n.
    a = {s: float(s) for s in range(5)}
    b = {s: float(s) + 1 + s / 10 for s in range(5)}
    assert signed_rank(a, b) == pytest.approx(2 / 32)
    # Pairing is by key: seeds only one side has (7) and non-finite values (4) drop out,
    # leaving 4 pairs (2 / 16); unpaired, the same numbers would give another p.
    b_more = {**b, 7: -100.0, 4: None}
    assert signed_rank(a, b_more) == pytest.approx(2 / 16)
    # Signed ranks of d = (-1, -2, +3, -4): W+ = 3; P(W+ <= 3) = 5/16, two-sided 10/16.
    c = {0: 1.0, 1: 2.0, 2: 6.0, 3: 4.0}
    d = {0: 2.0, 1: 4.0, 2: 3.0, 3: 8.0}
    assert signed_rank(c, d) == pytest.approx(10 / 16)
    assert signed_rank(a, dict(a)) == 1.0  # no pair differs
    assert math.isnan(signed_rank({0: 1.0}, {0: 2.0, 1: 3.0}))  # one pair: untestable
    assert mark([1, 2, 3, 4, 5], [6, 7, 8, 9, 10], 2 / 252, lower_is_better=False) == "-"


def test_mean_and_sample_std_skip_missing_values():
    mean, std, n = mean_std([1.0, None, 3.0, float("nan")])
    assert (mean, n) == (2.0, 2) and std == pytest.approx(math.sqrt(2.0))
    assert fmt_mean_std([1.0, 3.0]) == "2 ± 1.41"
    assert fmt_mean_std([1e-10, 3e-10]) == "2e-10 ± 1.4e-10"
    assert fmt_mean_std([]) == "n/a"


def test_p_values_compare_with_the_reference_in_the_same_setting_only(tmp_path):
    for seed in range(5):
        _run(tmp_path, f"ipc{seed}", {"algorithm": "mgsaea_ipc", "seed": seed},
             algorithm="mgsaea_ipc", seed=seed, m=3.0 + 0.1 * seed)
        _run(tmp_path, f"ea{seed}", {"algorithm": "nsga2", "seed": seed}, seed=seed,
             m=10.0 + seed)
        _run(tmp_path, f"a{seed}", {"algorithm": "nsga2", "scheme": "A", "seed": seed},
             scheme="A", seed=seed, m=1.0)
    runs = discover_runs(tmp_path)
    keys = ["algorithm", "scheme"]
    from tmopt.reporting.runs import group_runs
    rows = {tuple(r["setting"].values()): r
            for r in summarise(group_runs(runs, keys), STIFFNESS_METRICS, "mgsaea_ipc")}
    assert rows[("nsga2", "B")]["p_M_TM1"] == pytest.approx(2 / 252)
    assert rows[("nsga2", "B")]["mark_M_TM1"] == "-"
    assert math.isnan(rows[("nsga2", "A")]["p_M_TM1"])  # no MGSAEA-IPC run of scheme A
    assert math.isnan(rows[("mgsaea_ipc", "B")]["p_M_TM1"])  # the reference itself
    assert rows[("mgsaea_ipc", "B")]["M_TM1"][0] == pytest.approx(3.2)


def test_benchmark_table_and_figures_for_suite_runs(tmp_path):
    for seed in range(3):
        for algo, igd in (("mgsaea_ipc", 0.1), ("nsga2", 0.5)):
            _run(tmp_path, f"{algo}{seed}", {"algorithm": algo, "problem": "mw1",
                                             "seed": seed},
                 algorithm=algo, problem="mw1", seed=seed, igd=igd + 0.01 * seed,
                 hv=1 - igd, m=None, feasible_ratio=igd / 2 + 0.05 * seed)
    out = tmp_path / "out"
    files = {p.name for p in collect(tmp_path, out)}
    assert {"benchmarks.md", "benchmarks.csv", "benchmarks_igd.png",
            "benchmarks_hv.png"} <= files
    assert "table3.md" not in files  # no stiffness run
    text = (out / "benchmarks.md").read_text()
    # 3 vs 3 completely separated: exact p = 2/20 = 0.1, not significant at 0.05
    # feasible share of the evaluations: NSGA-II 0.25, 0.30, 0.35
    assert "| mw1 | NSGA-II | 3/3 | 3/3 | 0.3 ± 0.05 | 0.51 ± 0.01 | 0.100 = |" in text
    assert "| 100 ± 0 | 2 ± 0 |" in text


def test_command_line_errors_are_one_line(tmp_path, capsys):
    assert main([str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tmopt.collect: error:") and "\n" not in err
    assert main([str(tmp_path)]) == 2  # exists but holds no run


def test_several_sweeps_collected_as_one_compare_with_the_reference_at_another_budget(
        tmp_path):
    # Sweep 1: both algorithms at the small budget; sweep 2: NSGA-II alone at a large one.
    small, large = tmp_path / "small", tmp_path / "large"
    for seed in range(5):
        _run(small, f"ipc{seed}", {"algorithm": "mgsaea_ipc", "experiment": "results",
                                   "seed": seed}, algorithm="mgsaea_ipc", seed=seed, m=6.0 + seed)
        _run(large, f"ea{seed}", {"algorithm": "nsga2", "experiment": "paper", "seed": seed},
             seed=seed, m=4.0 + 0.1 * seed)
    out = tmp_path / "out"
    collect([small, large], out, fig10=False)
    table = (out / "table3.md").read_text()
    # 5 vs 5 separated, NSGA-II lower: p = 2/252, flagged as another setting's reference
    assert "| NSGA-II | paper | 5/5 | 5/5 |" in table and "| 0.008† + |" in table
    runs = (out / "runs.csv").read_text()
    assert "small/ipc0" in runs and "large/ea4" in runs
    with pytest.raises(FileNotFoundError, match="--out"):
        collect([small, large])


def test_an_algorithms_own_parameters_do_not_hide_its_reference(tmp_path):
    # C-MOEA/D run with algorithm.batch_size=1 in the same sweep as MGSAEA-IPC (which has
    # no batch_size): same problem and budget, so MGSAEA-IPC is its reference, unflagged.
    for seed in range(3):
        _run(tmp_path, f"c{seed}", {"algorithm": "cmoead", "algorithm.batch_size": 1,
                                    "seed": seed}, algorithm="cmoead", seed=seed, m=9.0)
        _run(tmp_path, f"i{seed}", {"algorithm": "mgsaea_ipc", "seed": seed},
             algorithm="mgsaea_ipc", seed=seed, m=3.0 + seed)
    from tmopt.reporting.runs import group_runs
    runs = discover_runs(tmp_path)
    keys = setting_keys(runs)
    assert "algorithm.batch_size" in keys
    assert {r.value("algorithm.batch_size") for r in runs} == {"", "1"}  # absent != null
    rows = summarise(group_runs(runs, keys), STIFFNESS_METRICS, "mgsaea_ipc")
    cmoead = next(r for r in rows if r["setting"]["algorithm"] == "cmoead")
    assert cmoead["reference"]["algorithm"] == "mgsaea_ipc"
    assert cmoead["p_M_TM1"] == rank_sum([9.0] * 3, [3.0, 4.0, 5.0])
    from tmopt.reporting.tables import markdown_rows
    _, body = markdown_rows(rows, STIFFNESS_METRICS, keys, "mgsaea_ipc")
    assert not any("†" in cell for row in body for cell in row)  # same budget: no flag


def test_two_sweeps_compared_setting_by_setting(tmp_path):
    from tmopt.reporting.compare import compare_sweeps

    for sweep, shift in (("a", 0.0), ("b", 0.5)):
        for seed in range(3):
            _run(tmp_path / sweep, f"mw1_{seed}", {"problem": "mw1", "seed": seed},
                 algorithm="mgsaea", problem="mw1", seed=seed, m=None,
                 igd=0.1 + shift + 0.01 * seed, hv=0.9 - shift - 0.01 * seed)
        _run(tmp_path / sweep, f"only_{sweep}", {"problem": "mw3"}, algorithm="mgsaea",
             problem=f"mw3{sweep}", m=None, igd=0.1, hv=0.5)
    text = compare_sweeps(tmp_path / "a", tmp_path / "b", ["problem", "algorithm"],
                          ("rbf", "gp"))
    lines = text.splitlines()
    assert lines[0].startswith("| problem | algorithm | runs | igd rbf | igd gp | p (igd) |")
    # only the setting present in both sweeps; B's IGD higher and HV lower: worse twice,
    # 3 vs 3 completely separated -> exact p = 0.1, which is not significant
    assert len(lines) == 3
    assert lines[2] == ("| mw1 | mgsaea | 3 / 3 | 0.11 ± 0.01 | 0.61 ± 0.01 | 0.100 = "
                        "| 0.89 ± 0.01 | 0.39 ± 0.01 | 0.100 = |")
    _run(tmp_path / "d", "mw5", {"problem": "mw5"}, problem="mw5", m=None, igd=0.1, hv=0.5)
    with pytest.raises(ValueError, match="no setting"):
        compare_sweeps(tmp_path / "a", tmp_path / "d", ["problem"])
    with pytest.raises(FileNotFoundError, match="does not exist"):
        compare_sweeps(tmp_path / "a", tmp_path / "c", ["problem"])


def test_labels_leave_out_keys_the_algorithm_does_not_have():
    from tmopt.reporting.tables import label

    assert label({"algorithm": "nsga2", "experiment": "paper",
                  "algorithm.batch_size": ""}) == "NSGA-II (experiment=paper)"
    assert label({"algorithm": "cmoead", "algorithm.batch_size": "100"}) == \
        "C-MOEA/D (algorithm.batch_size=100)"


def test_table3_headlines_heldout_m_keeps_the_search_draw_and_flags_the_floor(tmp_path):
    """Held-out M is the headline (and what p tests); the search draw sits beside it and
    in table3_search_draw.md, where numbers below the physical floor carry ‡k."""
    for seed in range(3):
        _run(tmp_path, f"i{seed}", {"algorithm": "mgsaea_ipc", "seed": seed},
             algorithm="mgsaea_ipc", seed=seed, m=4.0 + seed)
        _run(tmp_path, f"n{seed}", {"algorithm": "nsga2", "seed": seed}, seed=seed, m=9.0,
             below_floor=("identification.final_accuracy_TM1",) if seed else ())
    out = tmp_path / "out"
    collect(tmp_path, out, fig10=False)
    table = (out / "table3.md").read_text()
    header = table.splitlines()[2]
    assert header.index("M held-out") < header.index("p (M held-out)") \
        < header.index("M search draw")
    # NSGA-II: held-out 10 (tied) vs MGSAEA-IPC's 5, 6, 7: separated, p = 0.064 with ties
    assert "| NSGA-II | 3/3 | 3/3 | 10 ± 0 | 0.064 = | 9 ± 0 |" in table
    assert "M >= 3.48" in table
    draw = (out / "table3_search_draw.md").read_text()
    assert "1e-11 ± 0 ‡2" in draw  # two NSGA-II runs below the floor of the final accuracy
    paper = (out / "table3_vs_paper.md").read_text()
    assert "ours, held-out (mean of 3)" in paper and "ours, search draw (mean of 3)" in paper


def test_a_parameter_added_later_reads_as_its_default_in_older_runs(tmp_path):
    # problem.information_constraints was added hash-neutral with default "noise_free": a run
    # made before it (no key in config.yaml) ran with that default, so it is the same setting
    # as a newer run that spells the default out, and a different one from "noise_seed".
    old = _run(tmp_path, "old", {"seed": 0})
    for name, value in (("new", "noise_free"), ("other", "noise_seed")):
        path = _run(tmp_path, name, {"seed": 1, "problem.information_constraints": value},
                    seed=1)
        config = json.loads((path / "config.yaml").read_text())
        config["problem"]["information_constraints"] = value
        (path / "config.yaml").write_text(json.dumps(config))
    assert "information_constraints" not in json.loads((old / "config.yaml").read_text())["problem"]
    runs = {r.name: r for r in discover_runs(tmp_path)}
    key = "problem.information_constraints"
    assert runs["old"].value(key) == runs["new"].value(key) == "noise_free"
    assert runs["other"].value(key) == "noise_seed"
    assert runs["old"].value("problem.no_such_parameter") == ""  # not a parameter: absent


def test_an_argument_whose_earlier_behaviour_is_not_its_default_reads_as_that_value(tmp_path):
    # HASH_NEUTRAL_VALUES: an older qLogNEHVI run without gp_guard_max_iter ran uncapped
    # (None), whatever the constructor's default is now; a run naming 10 is another setting.
    for name, cap in (("old", "absent"), ("capped", 10)):
        path = _run(tmp_path, name, {"seed": 0}, algorithm="qlognehvi")
        config = json.loads((path / "config.yaml").read_text())
        config["algorithm"] = {"_target_": "tmopt.algorithms.qlognehvi.QLogNEHVI"}
        if cap != "absent":
            config["algorithm"]["gp_guard_max_iter"] = cap
        (path / "config.yaml").write_text(json.dumps(config))
    runs = {r.name: r for r in discover_runs(tmp_path)}
    assert runs["old"].value("algorithm.gp_guard_max_iter") == "None"
    assert runs["capped"].value("algorithm.gp_guard_max_iter") == "10"


def test_runs_whose_configurations_differ_where_no_override_says_so_are_not_pooled(tmp_path):
    # Two qLogNEHVI sweeps with the same overrides, made before and after the default of
    # gp_guard_max_iter changed (null, then 5): two configurations, two rows -- before,
    # collect averaged them as one setting (15 "runs" of 10 + 5).
    for seed in range(3):
        for name, cap in (("old", "absent"), ("new", 5)):
            path = _run(tmp_path, f"{name}{seed}", {"seed": seed}, algorithm="qlognehvi",
                        seed=seed, m=3.0 if cap == 5 else 9.0)
            config = json.loads((path / "config.yaml").read_text())
            config["algorithm"] = {"_target_": "tmopt.algorithms.qlognehvi.QLogNEHVI"}
            if cap != "absent":
                config["algorithm"]["gp_guard_max_iter"] = cap
            (path / "config.yaml").write_text(json.dumps(config))
    runs = discover_runs(tmp_path)
    assert "algorithm.gp_guard_max_iter" in setting_keys(runs)
    out = tmp_path / "out"
    collect(tmp_path, out, fig10=False)
    with open(out / "table3.csv") as fh:
        rows = {r["algorithm.gp_guard_max_iter"]: r for r in csv.DictReader(fh)}
    assert set(rows) == {"None", "5"}
    assert rows["None"]["n_complete"] == rows["5"]["n_complete"] == "3"


def test_seeds_alone_do_not_make_a_setting(tmp_path):
    for seed in range(3):
        _run(tmp_path, f"r{seed}", {"seed": seed}, seed=seed)
    assert setting_keys(discover_runs(tmp_path)) == ["problem", "algorithm"]
