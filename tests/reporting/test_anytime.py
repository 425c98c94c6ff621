"""tmopt.reporting.anytime: a run's report after its first k evaluations.

Archives made by hand, with numbers chosen so every expected value can be worked out;
the same view on real sweeps (and its agreement with the final Table 3) is in
tests/run/test_sweeps.py.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from tmopt.evaluation.archive import ArchiveData
from tmopt.reporting.anytime import curve_counts, parse_counts, prefix_values
from tmopt.reporting.collect import main

NAMES = ["convergence_time_TM1", "convergence_accuracy_TM1"]
STIFFNESS_LIKE = SimpleNamespace(objective_names=NAMES, m_weights=(1 / 60, 1e10))


def _archive(F, G) -> ArchiveData:
    F, G = np.asarray(F, float), np.asarray(G, float)
    n = len(F)
    return ArchiveData(X=np.zeros((n, 1)), F=F, G=G, failed=np.zeros(n, bool),
                       reason=[""] * n, seed=np.zeros(n, int), wall_time=np.zeros(n),
                       batch=np.arange(n))


def test_the_choice_after_k_evaluations_sees_only_the_first_k():
    #      time (s)  RMSE       constraint (<= 0 feasible)
    data = _archive([[90.0, 1e-10], [300.0, 3e-10], [60.0, 5e-11], [120.0, 1e-10]],
                    [[0.5], [-0.1], [2.0], [-0.2]])
    first = prefix_values(STIFFNESS_LIKE, data, 1)
    # nothing feasible yet: the least violating design (row 0), reported as infeasible
    assert first["chosen"] == {"feasible": False} and first["pareto_size"] == 0
    assert first["identification"]["M_TM1"] == pytest.approx(90 / 60 + 1.0)
    two = prefix_values(STIFFNESS_LIKE, data, 2)
    assert two["chosen"]["feasible"] and two["pareto_size"] == 1
    assert two["identification"]["convergence_time_TM1"] == 300.0
    assert two["identification"]["M_TM1"] == pytest.approx(5.0 + 3.0)  # Eq. 29
    # row 2 is better still but infeasible; row 3 dominates row 1
    four = prefix_values(STIFFNESS_LIKE, data, 4)
    assert four["n_evals"] == 4 and four["pareto_size"] == 1
    assert four["identification"]["M_TM1"] == pytest.approx(2.0 + 1.0)


def test_benchmark_prefixes_get_the_indicators_of_their_feasible_front():
    problem = SimpleNamespace(objective_names=["f1", "f2"], hv_ref_point=np.array([2.0, 2.0]))
    data = _archive([[1.0, 1.0], [0.0, 0.0], [0.5, 0.5]], [[0.0], [1.0], [-1.0]])
    assert prefix_values(problem, data, 1)["hv"] == pytest.approx(1.0)  # (2-1) x (2-1)
    # row 1 is infeasible; row 2 dominates row 0: HV (2-0.5)^2
    assert prefix_values(problem, data, 3)["hv"] == pytest.approx(2.25)
    # the feasible share of the prefix's evaluations (G <= 0): 1/1, then 2/3
    assert prefix_values(problem, data, 1)["feasible_ratio"] == 1.0
    assert prefix_values(problem, data, 3)["feasible_ratio"] == pytest.approx(2 / 3)
    front = np.array([[0.0, 1.0], [1.0, 0.0]])
    out = prefix_values(problem, data, 3, front)
    assert out["igd"] == pytest.approx(np.hypot(0.5, 0.5))  # both front points 0.707 away


def test_curve_counts_resolve_every_run_length_and_keep_the_asked_counts():
    runs = [SimpleNamespace(budget=100, n_evals=100), SimpleNamespace(budget=1000,
                                                                      n_evals=40)]
    grid = curve_counts(runs, [150], points=10)
    assert {10, 20, 100, 150, 200, 1000} <= set(grid) and 15 not in grid
    assert grid == sorted(set(grid))


def test_bad_counts_name_the_option(capsys):
    for text in ("", "0,10", "ten"):
        with pytest.raises(ValueError, match="--at must be comma-separated positive"):
            parse_counts(text)
    assert parse_counts("400, 300,400") == [300, 400]
    with pytest.raises(SystemExit):
        main(["some_dir", "--at", "x"])
    assert "--at must be comma-separated positive integers" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["some_dir", "--at", "10", "--at-seeds", "-1"])
    assert "--at-seeds must be an integer in [0, 100000], got -1" in capsys.readouterr().err


def test_prefix_scores_each_chosen_design_once_on_held_out_seeds(monkeypatch):
    """Held-out scoring of the anytime view (the headline): a design chosen at several k
    is simulated once; the block is the one metrics.json's ``heldout`` has."""
    import tmopt.reporting.anytime as anytime_module

    calls = []

    def fake_heldout(problem, X, best, front, used_seeds=None):
        calls.append(best)
        return {"heldout": {"M": {"mean": 10.0 + best}, "eq20_share": 1.0}}

    monkeypatch.setattr(anytime_module, "heldout_metrics", fake_heldout)
    data = _archive([[90.0, 1e-10], [300.0, 3e-10], [60.0, 5e-11], [120.0, 1e-10]],
                    [[0.5], [-0.1], [2.0], [-0.2]])
    cache: dict = {}
    chosen = [prefix_values(STIFFNESS_LIKE, data, k, heldout_cache=cache)["heldout"]
              for k in (1, 2, 3, 4)]
    assert [c["M"]["mean"] for c in chosen] == [10.0, 11.0, 11.0, 13.0]
    assert calls == [0, 1, 3]  # row 1 chosen at k = 2 and 3: simulated once
    assert "heldout" not in prefix_values(STIFFNESS_LIKE, data, 4)  # no cache: none


def test_evaluations_by_a_time_follow_the_evaluation_clock():
    from tmopt.reporting.anytime import evaluations_by, seconds_grid

    clock = {"evaluations": [87, 92, 97], "seconds": [0.5, 1.0, 2.0]}
    run = SimpleNamespace(status="complete", metrics={"evaluation_clock": clock,
                                                      "resumed_from": 0})
    assert [evaluations_by(run, t) for t in (0.1, 0.5, 1.5, 2.0)] == [0, 87, 92, 97]
    assert evaluations_by(run, 2.5) is None  # the run had ended: not counted as reached
    resumed = SimpleNamespace(status="complete", metrics={"evaluation_clock": clock,
                                                          "resumed_from": 40})
    assert evaluations_by(resumed, 1.0) is None  # its clock restarted at the resume
    grid = seconds_grid([run])
    assert grid[0] == pytest.approx(0.5) and grid[-1] == pytest.approx(2.0)
