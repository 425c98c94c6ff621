"""qLogNEHVI's reference-point rule: nadir of the feasible designs, of their front, of all.

    python experiments/qlognehvi_reference_point.py [--n-var 6] [--budget 120] [--seeds 0,1]
        [--rules feasible,front,all]

Runs qLogNEHVI (conf defaults otherwise) with each ``ref_point`` rule on MW3 and prints,
per run, IGD and HV of the final feasible front and the range of f1 it covers (MW3's
front spans f1 in [0, 1]); the last lines are the mean IGD per rule and, when both ran,
the ratio front / feasible. Two processes on two cores.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp

import numpy as np


def one_run(args: tuple[str, int, int, int]) -> tuple[str, int, float, float, float, float]:
    rule, seed, n_var, budget = args
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

    from tmopt.algorithms.qlognehvi import QLogNEHVI
    from tmopt.problems.suites import PymooBenchmark
    from tmopt.run.runner import run_optimisation

    problem = PymooBenchmark("mw3", n_var=n_var)
    res = run_optimisation(problem, QLogNEHVI(ref_point=rule), budget=budget, seed=seed,
                           progress=False, plots=False)
    a = res.archive
    feasible = np.all(a.G <= 0, axis=1) & ~a.failed
    F = a.F[feasible]
    lo = hi = float("nan")
    if len(F):
        front = F[NonDominatedSorting().do(F, only_non_dominated_front=True)]
        lo, hi = float(front[:, 0].min()), float(front[:, 0].max())
    igd = res.metrics.get("igd")
    return rule, seed, float("nan") if igd is None else igd, res.metrics.get("hv", 0.0), lo, hi


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n-var", type=int, default=6)
    ap.add_argument("--budget", type=int, default=120)
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--rules", default="feasible,front,all")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    rules = args.rules.split(",")
    jobs = [(r, s, args.n_var, args.budget) for s in seeds for r in rules]
    with mp.get_context("spawn").Pool(2) as pool:
        rows = pool.map(one_run, jobs)
    print(f"MW3, D = {args.n_var}, budget {args.budget}, seeds {seeds}")
    print("rule      seed   IGD      HV      front f1 range")
    for rule, seed, igd, hv, lo, hi in rows:
        print(f"{rule:9s} {seed:4d}  {igd:7.4f}  {hv:6.4f}  [{lo:.3f}, {hi:.3f}]")
    mean = {r: np.nanmean([row[2] for row in rows if row[0] == r]) for r in rules}
    for r in rules:
        print(f"mean IGD {r}: {mean[r]:.4f}")
    if {"front", "feasible"} <= set(rules):
        print(f"igd_ratio_front_over_feasible: {mean['front'] / mean['feasible']:.2f}")


if __name__ == "__main__":
    main()
