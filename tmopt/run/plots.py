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
        ax.set_xlabel(names[i])
        ax.set_ylabel(names[j] if m > 1 else "")
    axes[0][0].legend(fontsize=7)
    fig.suptitle(f"{problem.name}: {len(data)} real evaluations")
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
        vals = np.where(ok, data.F[:, k], np.inf)
        best = np.minimum.accumulate(vals)
        axes[0][k].plot(n, np.where(np.isfinite(best), best, np.nan))
        axes[0][k].set_xlabel("real evaluations")
        axes[0][k].set_ylabel(f"best feasible {problem.objective_names[k]}")
    axes[0][m].plot(n, np.cumsum(ok) / n)
    axes[0][m].set_xlabel("real evaluations")
    axes[0][m].set_ylabel("feasible share")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
