"""Run plots a scientist would publish: units on every axis, log scales where values span
decades, a visible note instead of an empty panel."""

from __future__ import annotations

import numpy as np

from tmopt.evaluation.archive import ArchiveData
from tmopt.run import plots


class _Problem:
    name = "p"
    objective_names = ["convergence_time_TM1", "convergence_accuracy_TM1"]


def _data(G: np.ndarray, F: np.ndarray) -> ArchiveData:
    n = len(F)
    return ArchiveData(X=np.zeros((n, 1)), F=F, G=G, failed=np.zeros(n, bool),
                       reason=[""] * n, seed=np.zeros(n, int), wall_time=np.zeros(n),
                       batch=np.zeros(n, int))


def _figure(monkeypatch, draw) -> list:
    kept = []
    monkeypatch.setattr(plots.plt, "close", kept.append)
    draw()
    return kept[0].axes


def test_axis_labels_carry_units():
    assert plots.axis_label("convergence_time_TM1") == "convergence time TM1 [s]"
    assert plots.axis_label("convergence_accuracy_TM2") == "convergence accuracy TM2 [s$^{-2}$]"
    assert plots.axis_label("f1") == "f1 [-]"


def test_accuracy_spanning_decades_is_drawn_on_a_log_axis(monkeypatch, tmp_path):
    F = np.array([[100.0, 1e-9], [200.0, 1e-11], [300.0, 1e-12]])
    data = _data(np.full((3, 1), -1.0), F)
    axes = _figure(monkeypatch, lambda: plots.plot_pareto(
        _Problem(), data, np.arange(3), tmp_path / "p.png"))
    assert axes[0].get_xscale() == "linear" and axes[0].get_yscale() == "log"
    assert axes[0].get_xlabel() == "convergence time TM1 [s]"
    axes = _figure(monkeypatch, lambda: plots.plot_convergence(
        _Problem(), data, tmp_path / "c.png"))
    assert [ax.get_yscale() for ax in axes] == ["linear", "log", "linear"]
    assert all(ax.get_xlabel() and "[" in ax.get_ylabel() for ax in axes)


def test_nothing_feasible_is_said_not_drawn_empty(monkeypatch, tmp_path):
    data = _data(np.ones((3, 1)), np.ones((3, 2)))
    axes = _figure(monkeypatch, lambda: plots.plot_convergence(
        _Problem(), data, tmp_path / "c.png"))
    for ax in axes[:2]:
        assert [t.get_text() for t in ax.texts] == ["no feasible design in 3 real evaluations"]
        assert len(ax.get_xticks()) == 0 and len(ax.get_yticks()) == 0
