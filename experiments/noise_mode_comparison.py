"""Held-out M of each algorithm searched under two noise modes, paired by seed (issue 18).

    python experiments/noise_mode_comparison.py multirun/results_table3 \
        multirun/results_information_table3 multirun/pilot_noise [--modes fixed information]

For every algorithm with complete stiffness runs in both modes: held-out M (the chosen
design's mean over the held-out seeds, docs/noise.md) per seed, mean ± std, the mean of
(mode B - mode A) over the seeds both have, the Wilcoxon signed-rank test on those pairs
and the rank-sum test on all runs (two-sided, exact; scipy.stats).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.stats import mannwhitneyu, wilcoxon

from tmopt.reporting.runs import COMPLETE, deduplicate, discover_runs


def heldout_m(dirs: list[Path], modes: tuple[str, str]) -> dict[str, dict[str, dict[int, float]]]:
    """algorithm -> mode -> seed -> held-out M of the chosen design (scheme B, k = 3)."""
    runs, _ = deduplicate([r for d in dirs for r in discover_runs(d)])
    table: dict[str, dict[str, dict[int, float]]] = {}
    for run in runs:
        mode = run.value("problem.noise")
        if run.status != COMPLETE or mode not in modes or not run.is_stiffness:
            continue
        if run.value("problem.scheme") != "B" or run.value("problem.n_freq") != "3":
            continue
        held = (run.metrics or {}).get("heldout") or {}
        if "M" in held:
            table.setdefault(run.value("algorithm"), {}).setdefault(mode, {})[run.seed] = \
                float(held["M"]["mean"])
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep_dirs", type=Path, nargs="+")
    parser.add_argument("--modes", nargs=2, default=["fixed", "information"])
    args = parser.parse_args()
    a, b = args.modes
    print(f"| algorithm | runs {a} / {b} | held-out M, {a} | held-out M, {b} | "
          f"mean paired change ({b} - {a}) | pairs better under {b} | p signed-rank | p rank-sum |")
    print("|---|---|---|---|---|---|---|---|")
    pooled: list[float] = []
    for algorithm, by_mode in sorted(heldout_m(args.sweep_dirs, (a, b)).items()):
        ma, mb = by_mode.get(a, {}), by_mode.get(b, {})
        if not ma or not mb:
            continue
        va, vb = np.array(list(ma.values())), np.array(list(mb.values()))
        seeds = sorted(set(ma) & set(mb))
        diff = np.array([mb[s] - ma[s] for s in seeds])
        p_pair = wilcoxon(diff).pvalue if len(seeds) >= 2 else float("nan")
        p_sum = mannwhitneyu(va, vb).pvalue if min(len(va), len(vb)) >= 2 else float("nan")
        print(f"| {algorithm} | {len(va)} / {len(vb)} | {va.mean():.2f} ± {va.std(ddof=1):.2f} | "
              f"{vb.mean():.2f} ± {vb.std(ddof=1):.2f} | {diff.mean():+.2f} ({len(seeds)} seeds) | "
              f"{int(np.sum(diff < 0))}/{len(seeds)} | {p_pair:.3f} | {p_sum:.3f} |")
        pooled += list(diff)
    if len(pooled) >= 2:  # every (algorithm, seed) pair: does the mode help across algorithms?
        d = np.array(pooled)
        print(f"| all pairs | | | | {d.mean():+.2f} ({len(d)} pairs) | {int(np.sum(d < 0))}/"
              f"{len(d)} | {wilcoxon(d).pvalue:.3f} | |")


if __name__ == "__main__":
    main()
