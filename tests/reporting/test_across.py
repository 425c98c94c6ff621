"""Across problems: the Friedman test and Holm's post-hoc on Demšar's worked example,
performance profiles on a hand example, and collect's across_problems.md."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import friedmanchisquare

from tests.reporting.test_collect import _run
from tmopt.reporting.across import block_table, performance_ratios, profile
from tmopt.reporting.collect import collect
from tmopt.reporting.runs import discover_runs, setting_keys
from tmopt.reporting.stats import average_ranks, friedman, holm, post_hoc_vs_control

# Demšar, JMLR 7 (2006), Table 6: AUC of C4.5, C4.5+m, C4.5+cf, C4.5+m+cf on 14 data sets,
# as printed (three decimals), except "voting": its printed 0.975 / 0.975 tie is broken
# (0.9751 / 0.9749) as the paper's average ranks imply (they were computed on unrounded
# AUCs; with the printed tie C4.5+cf and C4.5+m+cf would rank 2.929 and 1.929).
DEMSAR = np.array([
    [0.763, 0.768, 0.771, 0.798], [0.599, 0.591, 0.590, 0.569], [0.954, 0.971, 0.968, 0.967],
    [0.628, 0.661, 0.654, 0.657], [0.882, 0.888, 0.886, 0.898], [0.936, 0.931, 0.916, 0.931],
    [0.661, 0.668, 0.609, 0.685], [0.583, 0.583, 0.563, 0.625], [0.775, 0.838, 0.866, 0.875],
    [1.000, 1.000, 1.000, 1.000], [0.940, 0.962, 0.965, 0.962], [0.619, 0.666, 0.614, 0.669],
    [0.972, 0.981, 0.9751, 0.9749], [0.957, 0.978, 0.946, 0.970]])


def test_friedman_reproduces_demsars_worked_example():
    res = friedman(DEMSAR, lower_is_better=False)  # AUC: higher is better
    # Sec. 3.2.4: average ranks 3.143, 2.000, 2.893, 1.964; chi2_F = 9.28; F_F = 3.69,
    # above the critical F(3, 39) = 2.85 at 0.05
    np.testing.assert_allclose(res.ranks, [3.143, 2.000, 2.893, 1.964], atol=5e-4)
    assert res.chi2 == pytest.approx(9.28, abs=5e-3)
    assert res.f == pytest.approx(3.69, abs=5e-3)
    assert res.p_f < 0.05
    from scipy.stats import f as f_dist
    assert f_dist.ppf(0.95, 3, 39) == pytest.approx(2.85, abs=5e-3)


def test_holm_post_hoc_reproduces_demsars_comparison_with_c45():
    # Sec. 3.2.4: C4.5 as the control; SE = sqrt(4 * 5 / (6 * 14)) = 0.488; p = 0.016
    # (C4.5+m+cf), 0.019 (C4.5+m), 0.607 (C4.5+cf); Holm compares them with 0.05/3,
    # 0.05/2, 0.05: the first two are rejected, the third is not
    z, p, p_holm = post_hoc_vs_control(friedman(DEMSAR, lower_is_better=False), control=0)
    assert np.isnan(z[0]) and np.isnan(p_holm[0])
    np.testing.assert_allclose(np.abs(z[1:]), [2.342, 0.512, 2.416], atol=2e-3)
    np.testing.assert_allclose(p[1:], [0.019, 0.607, 0.016], atol=1.5e-3)
    assert list(p_holm[1:] < 0.05) == [True, False, True]


def test_friedman_statistic_equals_scipys_without_ties():
    T = np.random.default_rng(0).random((9, 5))
    assert friedman(T).chi2 == pytest.approx(friedmanchisquare(*T.T).statistic, rel=1e-12)
    assert friedman(T).p_chi2 == pytest.approx(friedmanchisquare(*T.T).pvalue, rel=1e-9)


def test_ranks_share_ties_and_infinity_ranks_last():
    T = np.array([[0.1, 0.1, np.inf], [0.3, 0.2, 0.1]])
    np.testing.assert_allclose(average_ranks(T), [(1.5 + 3) / 2, (1.5 + 2) / 2, (3 + 1) / 2])
    with pytest.raises(ValueError, match="without NaN"):
        friedman(np.array([[0.1, np.nan], [0.2, 0.3]]))


def test_holm_adjusted_p_values_by_hand():
    # sorted 0.005, 0.01, 0.03, 0.04 -> x4, x3, x2, x1 = 0.02, 0.03, 0.06, 0.04 -> running max
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03, 0.005]), [0.03, 0.06, 0.06, 0.02])
    assert holm([0.5, 0.9])[1] == 1.0  # capped at 1


def test_performance_profile_by_hand():
    # Dolan & Moré 2002, Eq. 1-2: three problems, two solvers; solver 2 fails problem 3;
    # problem 4 is solved by neither and is left out
    cost = np.array([[1.0, 2.0], [3.0, 1.5], [2.0, np.inf], [np.inf, np.inf]])
    ratios, unsolved = performance_ratios(cost)
    assert unsolved == 1
    np.testing.assert_allclose(ratios, [[1.0, 2.0], [2.0, 1.0], [1.0, np.inf]])
    rho = profile(ratios, np.array([1.0, 1.9, 2.0, 1e9]))
    np.testing.assert_allclose(rho, [[2 / 3, 1 / 3], [2 / 3, 1 / 3], [1.0, 2 / 3],
                                     [1.0, 2 / 3]])
    # HV is a score: the cost is 1 / HV, and HV = 0 is "not solved"
    ratios, unsolved = performance_ratios(np.array([[0.5, 0.25], [0.0, 0.4]]), False)
    np.testing.assert_allclose(ratios, [[1.0, 2.0], [np.inf, 1.0]])
    assert unsolved == 0


def _suite_runs(root, table):
    """Runs of algorithms (columns) on problems (rows), 3 seeds each, IGD = cell + seed/100
    (None for a cell that is None: no feasible design)."""
    algos = ["mgsaea_ipc", "kts", "nsga2"]
    for i, row in enumerate(table):
        for j, value in enumerate(row):
            for seed in range(3):
                igd = None if value is None else value + seed / 100
                _run(root, f"p{i}-{algos[j]}-{seed}",
                     {"algorithm": algos[j], "problem": f"mw{i + 1}", "seed": seed},
                     algorithm=algos[j], problem=f"mw{i + 1}", seed=seed, igd=igd,
                     hv=0.0 if igd is None else 1 - igd, m=None)


def test_block_table_takes_the_median_and_counts_no_feasible_design_as_worst(tmp_path):
    _suite_runs(tmp_path, [[0.1, 0.2, None], [0.3, 0.1, 0.2]])
    blocks, names, T = block_table(discover_runs(tmp_path), "igd", ["problem"], ["algorithm"])
    assert blocks == ["problem=mw1", "problem=mw2"] and names == ["kts", "mgsaea_ipc", "nsga2"]
    np.testing.assert_allclose(T, [[0.21, 0.11, np.inf], [0.11, 0.31, 0.21]])


def test_collect_writes_friedman_holm_and_profiles_across_problems(tmp_path):
    # KTS best on every problem, NSGA-II worst: ranks 1, 2, 3 on all 6 problems
    _suite_runs(tmp_path / "sweep", [[0.2, 0.1, 0.5]] * 6)
    out = tmp_path / "out"
    files = {p.name for p in collect(tmp_path / "sweep", out)}
    assert {"across_problems.md", "profiles.png"} <= files
    text = (out / "across_problems.md").read_text()
    # chi2 = 12 * 6 / 12 * (1 + 4 + 9 - 12) = 12; F = 5 * 12 / (6 * 2 - 12) -> infinite
    assert "IGD: N = 6 problems, k = 3 algorithms; Friedman chi2 = 12.000" in text
    # z = (1 - 2) / sqrt(3 * 4 / 36) = -1.732 for KTS, +1.732 for NSGA-II; p = 0.0833,
    # Holm: both 0.0833 * 2 -> 0.167: not significant with 6 problems
    assert "| kts | 1.000 | -1.732 | 0.083 | 0.167 | = |" in text
    assert "| mgsaea_ipc | 2.000 | reference | n/a | n/a |  |" in text


def test_a_parameter_only_one_algorithm_has_does_not_split_the_algorithms(tmp_path):
    import json
    _suite_runs(tmp_path / "sweep", [[0.2, 0.1, 0.5]] * 3)
    for path in (tmp_path / "sweep").glob("*-mgsaea_ipc-*"):
        config = json.loads((path / "config.yaml").read_text())
        (path / "config.yaml").write_text(json.dumps({**config, "algorithm": {"gap": 20}}))
        with open(path / ".hydra" / "overrides.yaml", "a") as fh:
            fh.write("- algorithm.gap=20\n")
    runs = discover_runs(tmp_path / "sweep")
    assert "algorithm.gap" in setting_keys(runs)  # it differs: 20 for IPC, absent for KTS
    out = tmp_path / "out"
    collect(tmp_path / "sweep", out)
    text = (out / "across_problems.md").read_text()
    assert "| mgsaea_ipc | 2.000 | reference |" in text and "| kts | 1.000 |" in text


def test_rescore_recomputes_the_indicators_from_the_archive(tmp_path):
    import csv
    import json

    from tests.algorithms.contract import cli_metrics
    run_dir = tmp_path / "sweep" / "r0"
    written = cli_metrics(run_dir, "problem=lircmop6", "problem.n_var=5", "algorithm=nsga2",
                          "algorithm.pop_size=20", "budget=60", "progress=false")
    stale = {**written, "hv": 0.123456, "igd": 9.0}  # as if scored against an older front
    (run_dir / "metrics.json").write_text(json.dumps(stale))
    for rescore, expect in ((False, 0.123456), (True, written["hv"])):
        out = tmp_path / f"out{rescore}"
        collect(tmp_path / "sweep", out, rescore=rescore)
        row = next(csv.DictReader((out / "runs.csv").open()))
        assert float(row["hv"]) == pytest.approx(expect, rel=1e-12)
