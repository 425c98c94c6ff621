"""Plots written into a run folder (headless: the Agg backend)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tmopt.evaluation.archive import ArchiveData  # noqa: E402


def _feasible(data: ArchiveData) -> np.ndarray:
    ok = ~data.failed
    if data.G.shape[1]:
        ok &= np.all(np.nan_to_num(data.G, nan=np.inf) <= 0.0, axis=1)
    return ok


#: Units of the quantities tmopt's problems name their objectives after (the stiffness
#: problem's Eqs. 18-19); benchmark objectives are dimensionless.
QUANTITY_UNITS = {"convergence_time": "s", "convergence_accuracy": "s$^{-2}$"}
#: An axis is drawn on a log scale when its positive values span this factor or more.
DECADES_FOR_LOG = 100.0


def axis_label(name: str) -> str:
    """``name [unit]`` for a known quantity, ``name [-]`` (dimensionless) otherwise."""
    unit = next((u for q, u in QUANTITY_UNITS.items() if name.startswith(q)), "-")
    return f"{name.replace('_', ' ')} [{unit}]"


def log_if_spanning_decades(ax, values, axis: str = "y") -> None:
    """Log scale on ``axis`` when ``values`` are positive and span two decades or more."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if len(v) and np.all(v > 0) and v.max() / v.min() >= DECADES_FOR_LOG:
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")


def note_nothing_to_draw(ax, text: str) -> None:
    """A visible note instead of an empty panel with meaningless ticks."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=9,
            color="0.3", wrap=True)
    ax.set_xticks([])
    ax.set_yticks([])


def plot_pareto(problem, data: ArchiveData, pareto: np.ndarray, path: Path,
                pf: np.ndarray | None = None) -> None:
    """Objective space: all evaluations, feasible ones, the final set and the true front."""
    names = problem.objective_names
    m = data.F.shape[1]
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)] or [(0, 0)]
    pairs = pairs[:6]
    fig, axes = plt.subplots(1, len(pairs), figsize=(4.5 * len(pairs), 4), squeeze=False)
    ok = _feasible(data)
    for ax, (i, j) in zip(axes[0], pairs):
        if pf is not None and m > 1:
            ax.plot(pf[:, i], pf[:, j], ".", ms=2, color="0.6", label="true front")
        ax.plot(data.F[~ok, i], data.F[~ok, j], "x", ms=3, color="tab:red", alpha=0.4,
                label="infeasible")
        ax.plot(data.F[ok, i], data.F[ok, j], "o", ms=3, color="tab:blue", alpha=0.4,
                label="feasible")
        if len(pareto):
            ax.plot(data.F[pareto, i], data.F[pareto, j], "o", ms=5, mfc="none",
                    color="k", label="final set")
        ax.set_xlabel(axis_label(names[i]))
        ax.set_ylabel(axis_label(names[j]) if m > 1 else "")
        shown = np.isfinite(data.F[:, i]) & np.isfinite(data.F[:, j])
        log_if_spanning_decades(ax, data.F[shown, i], "x")
        log_if_spanning_decades(ax, data.F[shown, j], "y")
    axes[0][0].legend(fontsize=7)
    feasible_note = "" if ok.any() else " (none feasible)"
    fig.suptitle(f"{problem.name}: {len(data)} real evaluations\n{int(ok.sum())} feasible, "
                 f"final set of {len(pareto)}{feasible_note}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_convergence(problem, data: ArchiveData, path: Path) -> None:
    """Best feasible value of each objective and the feasible share against evaluations."""
    ok = _feasible(data)
    n = np.arange(1, len(data) + 1)
    m = data.F.shape[1]
    fig, axes = plt.subplots(1, m + 1, figsize=(4 * (m + 1), 3.5), squeeze=False)
    for k in range(m):
        ax = axes[0][k]
        ax.set_title(f"best feasible {problem.objective_names[k].replace('_', ' ')}", fontsize=9)
        if not ok.any():
            note_nothing_to_draw(ax, f"no feasible design in {len(data)} real evaluations")
            continue
        vals = np.where(ok, data.F[:, k], np.inf)
        best = np.minimum.accumulate(vals)
        shown = np.where(np.isfinite(best), best, np.nan)
        ax.plot(n, shown)
        ax.set_xlabel("real evaluations")
        ax.set_ylabel(axis_label(problem.objective_names[k]))
        log_if_spanning_decades(ax, shown)
    axes[0][m].plot(n, 100 * np.cumsum(ok) / n)
    axes[0][m].set_xlabel("real evaluations")
    axes[0][m].set_ylabel("feasible share of evaluations so far [%]")
    axes[0][m].set_ylim(-2, 102)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
