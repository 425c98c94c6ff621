"""Regenerate and validate the offline Pareto front of every suite problem.

Usage: python experiments/check_fronts.py [--points 2000] [--n-var 10] [--nsga2 BUDGET]
                                          [--only mw3,dascmop1]

One line per problem: sizes, how the front is obtained, and the checks
  attained   max |F(x) - front| over designs built for every front point and evaluated by
             the real (pymoo) problem, and their largest constraint value (<= 0: feasible);
  nd         every front point non-dominated by the others;
  brute      2-objective problems: how many front points some feasible point of a brute-
             force grid (every direction x every distance) dominates (must be 0), and the
             largest distance from a grid point the front does not dominate to the front;
  pymoo      largest distance from pymoo's own front (where pymoo computes one offline) to
             ours, or "download" where pymoo would download it;
  nsga2      with --nsga2 BUDGET: IGD of NSGA-II (pop 100, seed 0) after BUDGET evaluations,
             and how many front points its final feasible set dominates (must be 0).
Exit status 1 if any check fails.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings

import numpy as np

from tmopt.metrics import igd
from tmopt.problems.fronts import (
    FRONT_SOURCE,
    dascmop,
    front_designs,
    front_sample,
    lircmop,
    mw,
)
from tmopt.problems.fronts.sampling import grid_front, nondominated, nondominated_index
from tmopt.problems.suites import SUITE_PROBLEMS, PymooBenchmark

warnings.filterwarnings("ignore", category=RuntimeWarning)


def attained(p: PymooBenchmark, points: int) -> tuple[float, float]:
    sample = front_sample(p.name, p.n_obj, points, p.difficulty)
    X = front_designs(p.name, p.n_var, p.n_obj, float(p.xu[0]), sample)
    out = p.evaluate(X, return_as_dictionary=True)
    return float(np.abs(out["F"] - sample.F).max()), float(out["G"].max())


def brute_grid(p: PymooBenchmark) -> np.ndarray | None:
    if p.n_obj != 2:
        return None
    if p.name.startswith("lircmop"):
        k = int(p.name[7:])
        return None if k <= 4 else nondominated(lircmop.design_grid(k, 800, 80))
    if p.name.startswith("mw"):
        (lo, hi), curve, shift, _ = mw._CURVES[int(p.name[2:])]
        base = np.column_stack(curve(np.linspace(lo, hi, 1500)))
        s = np.linspace(0, 0.8, 400) if shift is not None else np.geomspace(1, 2, 400)
        return grid_front(base, mw.violation(int(p.name[2:])), s,
                          None if shift is None else np.asarray(shift, float))
    eta, zeta, gamma = dascmop.triplet(p.difficulty)
    g_lo, g_hi = dascmop.g_range(zeta)
    t = np.linspace(0, 1, 3000)
    t = t[np.sin(20 * np.pi * t) >= 2 * eta - 1]
    return grid_front(dascmop._base2(int(p.name[7:]), t) + g_lo,
                      lambda F: dascmop.type3(F, gamma).max(1),
                      np.linspace(0, min(g_hi - g_lo, 1.0), 400), np.ones(2))


def brute(front: np.ndarray, grid: np.ndarray) -> tuple[int, float]:
    nd = nondominated_index(np.vstack([front, grid]))
    dominated = int(len(front) - np.isin(np.arange(len(front)), nd).sum())
    free = grid[nd[nd >= len(front)] - len(front)]
    dist = float(np.max(np.min(np.linalg.norm(free[:, None] - front[None], axis=2), axis=1))) \
        if len(free) else 0.0
    return dominated, dist


def pymoo_distance(p: PymooBenchmark, front: np.ndarray) -> str:
    from pymoo.problems import get_problem
    from pymoo.util.remote import Remote

    def refuse(*a, **k):
        raise ConnectionError("download")

    if p.name.startswith("lircmop"):
        return "not in pymoo"
    real, Remote.load = Remote.load, refuse
    try:
        kwargs = {"n_obj": p.n_obj} if p.n_obj != 2 and not p.name.startswith("dascmop") else {}
        args = (p.difficulty,) if p.name.startswith("dascmop") else ()
        theirs = np.asarray(get_problem(p.name, *args, **kwargs).pareto_front(), float)
    except ConnectionError:
        return "download"
    finally:
        Remote.load = real
    d = np.min(np.linalg.norm(theirs[:, None] - front[None], axis=2), axis=1).max()
    return f"{d:.1e}"


def nsga2(p: PymooBenchmark, budget: int, front: np.ndarray) -> tuple[float, int]:
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.optimize import minimize

    res = minimize(p, NSGA2(pop_size=100), ("n_evals", budget), seed=0, verbose=False)
    pop = res.pop
    F, G = pop.get("F"), pop.get("G")
    F = F[np.all(G <= 0, axis=1)]
    if len(F) == 0:
        return float("nan"), 0
    dominated = int(len(front) - np.isin(np.arange(len(front)),
                                         nondominated_index(np.vstack([front, F + 1e-9]))).sum())
    return igd(F, front), dominated


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=2000)
    ap.add_argument("--n-var", type=int, default=None, help="default: published default")
    ap.add_argument("--nsga2", type=int, default=0, metavar="BUDGET")
    ap.add_argument("--only", default="", help="comma-separated problem names")
    args = ap.parse_args()
    names = [n for n in SUITE_PROBLEMS if not args.only or n in args.only.split(",")]
    ok = True
    print(f"{'problem':10} {'D':>3} {'M':>2} {'C':>3} {'source':38} {'pts':>5} "
          f"{'attained dF / maxG':>20} nd  {'brute dom/dist':>15} {'pymoo':>9}"
          + ("  nsga2 igd/dom" if args.nsga2 else "") + "  time")
    for name in names:
        t0 = time.perf_counter()
        p = PymooBenchmark(name, n_var=args.n_var, front_points=args.points)
        front = p.pareto_front()
        dF, maxG = attained(p, args.points)
        nd = len(nondominated_index(front)) == len(front)
        grid = brute_grid(p)
        dom, dist = brute(front, grid) if grid is not None else (0, 0.0)
        line = (f"{name:10} {p.n_var:3d} {p.n_obj:2d} {p.n_ieq_constr:3d} "
                f"{FRONT_SOURCE[name]:38} {len(front):5d} {dF:9.1e} / {maxG:8.1e} "
                f"{'ok' if nd else 'NO'}  "
                + (f"{dom:5d} / {dist:7.1e}" if grid is not None else f"{'-':>15}")
                + f" {pymoo_distance(p, front):>9}")
        ok &= dF < 1e-9 and maxG <= 1e-9 and nd and dom == 0
        if args.nsga2:
            value, dominated = nsga2(p, args.nsga2, front)
            line += f"  {value:8.2e} / {dominated}"
            ok &= dominated == 0
        print(line + f"  {time.perf_counter() - t0:.1f}s", flush=True)
    print("all checks passed" if ok else "SOME CHECKS FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
