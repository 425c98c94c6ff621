"""Algorithms compared across problems: performance profiles, Friedman + Holm.

A sweep's per-problem tables test each algorithm against the reference on one problem at
a time (Wilcoxon rank-sum over seeds). Across problems the question is which algorithm
is better *in general*; each problem (a *block*: every setting but the algorithm) then
contributes one number per algorithm, the median over its seeds (IGD: a run without a
feasible design counts as infinitely far; HV: as 0, as in the final tables).

* **Performance profiles** (Dolan & Moré, Math. Program. 91, 2002): with cost
  ``t_{p,s}`` of algorithm s on problem p (IGD, or 1/HV), the ratio
  ``r_{p,s} = t_{p,s} / min_s t_{p,s}`` and ``rho_s(tau) = |{p : r_{p,s} <= tau}| / n_p``,
  the share of problems on which s is within a factor tau of the best; ``rho_s(1)`` is
  the share it wins (ties count for each), ``rho_s(tau -> inf)`` the share it solves at
  all. Problems that no algorithm solves (every cost infinite) are left out and counted.
* **Friedman test with Holm's post-hoc against the reference** (Demšar, JMLR 7, 2006;
  :mod:`tmopt.reporting.stats`): average ranks over the problems, the Iman-Davenport F
  test of "all algorithms are equivalent", then each algorithm against the reference
  with Holm-adjusted p-values.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tmopt.reporting.runs import COMPLETE, RunRecord
from tmopt.reporting.stats import ALPHA, fmt_p, friedman, post_hoc_vs_control

#: metric -> (lower is better, value of a complete run without a feasible design)
ACROSS_METRICS = {"igd": (True, math.inf), "igd_plus": (True, math.inf), "hv": (False, 0.0)}


def block_table(runs: Sequence[RunRecord], metric: str, keys: Sequence[str],
                treatment_keys: Sequence[str]) -> tuple[list[str], list[str], np.ndarray]:
    """(blocks, treatments, table): the median over seeds of ``metric`` per block (the
    values of ``keys``) and treatment (the values of ``treatment_keys``, e.g. the
    algorithm), complete runs only; blocks missing a treatment are left out."""
    lower, missing = ACROSS_METRICS[metric]
    cells: dict[tuple[str, str], list[float]] = {}
    for run in runs:
        if run.status != COMPLETE:
            continue
        block = ", ".join(f"{k}={run.value(k)}" for k in keys) or "all"
        treat = ", ".join(str(run.value(k)) for k in treatment_keys)
        value = (run.metrics or {}).get(metric)
        cells.setdefault((block, treat), []).append(
            missing if value is None or not math.isfinite(value) else float(value))
    blocks = sorted({b for b, _ in cells})
    treatments = sorted({t for _, t in cells})
    full = [b for b in blocks if all((b, t) in cells for t in treatments)]
    table = np.array([[float(np.median(cells[(b, t)])) for t in treatments] for b in full])
    return full, treatments, table.reshape(len(full), len(treatments))


def performance_ratios(table: np.ndarray, lower_is_better: bool = True
                       ) -> tuple[np.ndarray, int]:
    """Dolan-Moré ratios ``r_{p,s}`` (inf: not solved) of the problems some algorithm
    solves, and the number of problems left out because none does.

    ``table``: (n_problems, n_algorithms) costs (lower_is_better) or scores such as HV,
    whose cost is taken as 1 / score (0: not solved).
    """
    T = np.asarray(table, dtype=float)
    with np.errstate(divide="ignore"):
        cost = T if lower_is_better else np.where(T > 0, 1.0 / T, math.inf)
    cost = np.where(np.isfinite(cost) & (cost >= 0), cost, math.inf)
    best = cost.min(axis=1)
    solved = np.isfinite(best)
    cost, best = cost[solved], best[solved]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratios = np.where(best[:, None] > 0, cost / best[:, None],
                          np.where(cost == 0, 1.0, math.inf))
    return ratios, int((~solved).sum())


def profile(ratios: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """``rho_s(tau)`` for every tau (rows) and algorithm (columns)."""
    R = np.asarray(ratios, dtype=float)
    if R.size == 0:
        return np.zeros((len(taus), R.shape[1] if R.ndim == 2 else 0))
    return (R[None, :, :] <= np.asarray(taus, dtype=float)[:, None, None]).mean(axis=1)


def friedman_rows(blocks: list[str], treatments: list[str], table: np.ndarray, metric: str,
                  reference: str | None) -> tuple[list[str], list[list[str]], str]:
    """Markdown rows (algorithm, average rank, z, p, Holm p, mark) and a sentence with
    the Friedman / Iman-Davenport result."""
    lower, _ = ACROSS_METRICS[metric]
    header = ["algorithm", f"average rank ({metric.upper()})", "z vs reference",
              "p vs reference", "Holm p", ""]
    if len(blocks) < 2 or len(treatments) < 2:
        return header, [], (f"{metric.upper()}: not tested ({len(blocks)} problem(s) with "
                            f"every algorithm, {len(treatments)} algorithm(s)).")
    res = friedman(table, lower_is_better=lower)
    control = treatments.index(reference) if reference in treatments else None
    z = p = ph = np.full(len(treatments), np.nan)
    if control is not None:
        z, p, ph = post_hoc_vs_control(res, control)
    body = []
    for i in np.argsort(res.ranks, kind="stable"):
        mark = "" if not math.isfinite(ph[i]) else (
            "=" if ph[i] >= ALPHA else "+" if z[i] < 0 else "-")
        body.append([treatments[i], f"{res.ranks[i]:.3f}",
                     "reference" if i == control else
                     f"{z[i]:.3f}" if math.isfinite(z[i]) else "n/a",
                     fmt_p(p[i]), fmt_p(ph[i]), mark])
    verdict = "differ" if res.p_f < ALPHA else "do not differ significantly"
    text = (f"{metric.upper()}: N = {res.n_problems} problems, k = {res.n_algorithms} "
            f"algorithms; Friedman chi2 = {res.chi2:.3f} (p = {fmt_p(res.p_chi2)}), "
            f"Iman-Davenport F = {res.f:.3f} (p = {fmt_p(res.p_f)}): the algorithms "
            f"{verdict} at {ALPHA}.")
    return header, body, text
