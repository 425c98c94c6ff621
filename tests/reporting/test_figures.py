"""Collect's figures: units on the axes, log scales where values span decades, a visible
note instead of an empty panel (synthetic summary rows, no sweep needed)."""

from __future__ import annotations

import numpy as np

from tmopt.reporting import figures


def _axes(monkeypatch, draw) -> list:
    kept = []
    monkeypatch.setattr(figures.plt, "close", kept.append)
    draw()
    return kept[0].axes


def _box_row(problem: str, algorithm: str, igd: list[float]) -> dict:
    return {"setting": {"problem": problem, "algorithm": algorithm}, "values": {"igd": igd}}


def test_benchmark_boxes_log_when_spanning_decades_and_note_when_empty(monkeypatch, tmp_path):
    rows = [_box_row("mw1", "nsga2", [1e-3, 2e-3]), _box_row("mw1", "ssde", [0.5, 0.8]),
            _box_row("mw11", "nsga2", [None, None]), _box_row("mw3", "nsga2", [0.1, None])]
    axes = _axes(monkeypatch, lambda: figures.benchmark_boxes(rows, "igd", "t",
                                                              tmp_path / "b.png"))
    mw1, mw11, mw3 = axes[:3]
    assert mw1.get_yscale() == "log" and mw1.get_ylabel() == "IGD [-]"
    assert mw3.get_yscale() == "linear"
    assert [t.get_text() for t in mw3.get_xticklabels()] == ["NSGA-II (n=1/2)"]
    assert [t.get_text() for t in mw1.get_xticklabels()] == ["NSGA-II (n=2/2)", "SSDE (n=2/2)"]
    assert [t.get_text() for t in mw11.texts] == [
        "no run has a finite IGD (no feasible design, or no reference front)"]
    assert len(mw11.get_yticks()) == 0


def test_fig9_without_stiffness_rows_says_so(monkeypatch, tmp_path):
    axes = _axes(monkeypatch, lambda: figures.fig9([], tmp_path / "f9.png"))
    assert [t.get_text() for t in axes[0].texts] == [
        "no stiffness runs with a scheme and k to draw"]
    assert "[-]" in axes[0].get_ylabel()


def test_anytime_panel_without_finite_values_says_so(monkeypatch, tmp_path):
    row = {"setting": {"problem": "mw11", "algorithm": "nsga2", "evaluations": 100},
           "igd": (np.nan, np.nan), "n_complete": 1, "n_runs": 1}
    axes = _axes(monkeypatch, lambda: figures.anytime_curves([row], "igd",
                                                             tmp_path / "a.png"))
    assert [t.get_text() for t in axes[0].texts] == [
        "no finite IGD in any run (no feasible design yet)"]


def test_fig8_panel_of_a_scheme_without_runs_has_a_note_and_no_ticks(monkeypatch, tmp_path):
    axes = _axes(monkeypatch, lambda: figures.fig8([], tmp_path / "f8.png"))
    panels = [ax for ax in axes if ax.texts]  # the twin accuracy axes carry no note
    assert [ax.texts[0].get_text() for ax in panels] == [
        f"no runs of scheme {s}" for s in "ABC"]
    assert all(len(ax.get_xticks()) == 0 and len(ax.get_yticks()) == 0 for ax in axes)


def _scheme_row(scheme: str, k: int, noise: str, heldout: list, search: list,
                feasible: float = 1.0) -> dict:
    return {"setting": {"scheme": scheme, "problem.n_freq": k, "problem.noise": noise},
            "values": {"heldout_M": heldout, "M_TM1": search},
            "chosen_feasible": (feasible, 0.0)}


def test_fig9_draws_medians_with_quartiles_every_run_and_the_floor(monkeypatch, tmp_path):
    # one stuck run (M 100) must not move the line: the median of 6, 7, 100 is 7
    rows = [_scheme_row("B", 1, "fixed", [6.0, 7.0, 100.0], [5.0, 5.5, 6.0]),
            _scheme_row("B", 2, "fixed", [8.0, 9.0, None], [6.0, 7.0, 8.0], feasible=2 / 3)]
    axes = _axes(monkeypatch, lambda: figures.fig9(rows, tmp_path / "f9.png", 3.48))
    a, b, c = axes
    assert [t.get_text() for t in a.texts] == ["no runs of scheme A"]
    series = {c.get_label(): c.lines[0] for c in b.containers}  # errorbar: line, caps, bars
    np.testing.assert_allclose(series["problem.noise=fixed, held-out"].get_ydata(), [7.0, 8.5])
    np.testing.assert_allclose(series["problem.noise=fixed, search draw"].get_ydata(),
                               [5.5, 7.0])
    held = next(c for c in b.containers if c.get_label().endswith("held-out"))
    bar = held.lines[2][0].get_segments()[0]  # k = 1: from the lower to the upper quartile
    np.testing.assert_allclose(bar[:, 1], np.percentile([6.0, 7.0, 100.0], [25, 75]))
    lines = {ln.get_label(): ln for ln in b.get_lines()}
    dots = [ln for ln in b.get_lines() if ln.get_label() == "_runs"]
    assert sorted(y for ln in dots for y in ln.get_ydata()) == [6.0, 7.0, 8.0, 9.0, 100.0]
    assert lines["physical floor M = 3.48"].get_ydata()[0] == 3.48
    assert [tuple(ln.get_xdata()) for ln in b.get_lines() if ln.get_label() == "_infeasible"] \
        == [(2.0,)]
    assert b.get_yscale() == "log"  # shared: every value is positive


def test_settings_at_one_k_are_left_out_of_figs_8_9_and_the_panel_says_why(monkeypatch,
                                                                          tmp_path):
    # Table 3's algorithms (k = 3 only) collected beside a sweep over k: only the sweep's
    # curve is drawn; a scheme with nothing but single-k settings says so
    rows = [_scheme_row("B", 1, "fixed", [6.0], [5.0]), _scheme_row("B", 2, "fixed", [8.0], [6.0]),
            _scheme_row("B", 3, "information", [7.0], [7.0]),
            _scheme_row("A", 3, "fixed", [9.0], [9.0])]
    axes = _axes(monkeypatch, lambda: figures.fig9(rows, tmp_path / "f9.png"))
    a, b, _ = axes
    assert [t.get_text() for t in a.texts] == [
        "scheme A: each setting at one k (3),\nno curve against k (table3.md lists them)"]
    assert {c.get_label() for c in b.containers} == {"problem.noise=fixed, held-out",
                                                    "problem.noise=fixed, search draw"}
