"""Surrogate overhead of one MGSAEA-IPC iteration (fit + ``wmax`` surrogate generations).

Setting (the stiffness problem's size): D = 18 variables, 2 objectives, constraints in
two groups (MW3 at n_var=18 with ``constraint_groups=split``: key group g1, then g2),
a population of ``--n`` real evaluations (the training set; also the surrogate
population NI), ``wmax`` = 20 generations, ``mu`` = 5 new designs per iteration.

Per iteration it prints the wall and CPU seconds of ``ask`` (fit + 20 generations +
choice of the 5 designs) and ``tell`` (population and archive update), split into model
fitting, model prediction and the evolutionary machinery (SPEA2 fitness, truncation,
variation). Two references are measured in the same process:

* cold vs warm fit: the first iteration fits fresh models; later ones refit the same
  model objects (a surrogate with warm start reuses its hyperparameters);
* ``--reference free``: the same iterations with a zero-cost analytic stand-in model,
  i.e. the cost of everything except the surrogate.

The machine is shared: the load average and the CPU/wall ratio are printed with every
run so the numbers can be judged.

Usage:
    python experiments/bench_mgsaea_iteration.py [--n 300] [--iters 4] [--surrogate gp]
        [--stage 1|2] [--gp max_iter=30] [--gp refit_every=5] [--reference free|none]
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial

import numpy as np
import torch

from tmopt.algorithms.mgsaea import MGSAEAIPC
from tmopt.evaluation.evaluator import Evaluator
from tmopt.problems.suites import PymooBenchmark
from tmopt.surrogates.base import Surrogate


class Timed(Surrogate):
    """Wraps a surrogate and adds its fit/predict seconds to a shared dict."""

    def __init__(self, inner: Surrogate, clock: dict) -> None:
        self.inner, self.clock = inner, clock

    def fit(self, X, Y):
        t = time.perf_counter()
        self.inner.fit(X, Y)
        self.clock["fit"] += time.perf_counter() - t
        return self

    def predict(self, X):
        t = time.perf_counter()
        out = self.inner.predict(X)
        self.clock["predict"] += time.perf_counter() - t
        self.clock["n_predict"] += 1
        return out

    def predict_mean(self, X):
        t = time.perf_counter()
        out = self.inner.predict_mean(X)
        self.clock["predict"] += time.perf_counter() - t
        self.clock["n_predict"] += 1
        return out


class Free(Surrogate):
    """Zero-cost stand-in: a fixed random linear map (the EA's own cost, no model)."""

    def fit(self, X, Y):
        X, Y = self.check_training_data(X, Y)
        self.W = np.random.default_rng(0).standard_normal((X.shape[1], Y.shape[1]))
        return self

    def predict(self, X):
        mean = np.asarray(X) @ self.W
        return mean, np.zeros_like(mean)


def make_factory(kind: str, gp_options: dict | None = None):
    if kind == "free":
        return Free
    if kind == "gp":
        from tmopt.surrogates.gp import GPSurrogate

        return partial(GPSurrogate, **(gp_options or {}))
    if kind == "rbf":
        from tmopt.surrogates.rbf import RBFSurrogate

        return RBFSurrogate
    raise SystemExit(f"unknown surrogate {kind!r}; choose gp, rbf or free")


def bench(kind: str, n: int, iters: int, stage: int, seed: int,
          gp_options: dict | None = None) -> list[dict]:
    problem = PymooBenchmark("mw3", n_var=18, constraint_groups="split")
    clock = {"fit": 0.0, "predict": 0.0, "n_predict": 0}
    inner = make_factory(kind, gp_options)
    extra = {"gap": 1, "threshold": 1e9} if stage == 2 else {}
    alg = MGSAEAIPC(n_init=n, surrogate=partial(lambda: Timed(inner(), clock)), **extra)
    budget = n + alg.mu * iters
    alg.setup(problem, budget=budget, seed=seed)
    ev = Evaluator(problem, budget, seed=seed)
    alg.tell(ev.evaluate(alg.ask()))  # the initial sample (real evaluations, not timed)
    rows = []
    for it in range(iters):
        for k in clock:
            clock[k] = 0
        w0, c0 = time.perf_counter(), time.process_time()
        X = alg.ask()
        w1, c1 = time.perf_counter(), time.process_time()
        batch = ev.evaluate(X)
        w2 = time.perf_counter()
        alg.tell(batch)
        w3 = time.perf_counter()
        rows.append({"iter": it + 1, "ask": w1 - w0, "tell": w3 - w2,
                     "fit": clock["fit"], "predict": clock["predict"],
                     "n_predict": clock["n_predict"], "stage": alg.stage,
                     "granularity": alg.info().get("granularity"),
                     "models": alg.info().get("models"), "cpu_ask": c1 - c0})
    return rows


def show(label: str, rows: list[dict]) -> None:
    print(f"\n{label}")
    print(" iter  stage granularity models | ask[s]  fit[s]  predict[s] (calls)  EA[s] | "
          "tell[s] | ask CPU[s]")
    for r in rows:
        ea = r["ask"] - r["fit"] - r["predict"]
        print(f" {r['iter']:4d}  {r['stage']:5d} {r['granularity']!s:>11} {r['models']!s:>6} | "
              f"{r['ask']:6.2f}  {r['fit']:6.2f}  {r['predict']:6.2f} ({r['n_predict']:3d})"
              f"       {ea:5.2f} | {r['tell']:6.3f}  | {r['cpu_ask']:6.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=300, help="population = training points")
    ap.add_argument("--iters", type=int, default=4)
    ap.add_argument("--surrogate", default="gp", choices=["gp", "rbf", "free"])
    ap.add_argument("--stage", type=int, default=1, choices=[1, 2])
    ap.add_argument("--reference", default="free", choices=["free", "none"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--gp", action="append", default=[], metavar="KEY=INT",
                    help="GPSurrogate option, e.g. --gp max_iter=30 --gp refit_every=5")
    args = ap.parse_args()
    print(f"MGSAEA-IPC iteration overhead: n={args.n}, D=18, wmax=20, mu=5, stage {args.stage}; "
          f"torch threads={torch.get_num_threads()}, cores={os.cpu_count()}, "
          f"load average={os.getloadavg()[0]:.2f}")
    gp_options = {k: int(v) for k, v in (o.split("=", 1) for o in args.gp)}
    if gp_options:
        print(f"GPSurrogate options: {gp_options}")
    rows = bench(args.surrogate, args.n, args.iters, args.stage, args.seed, gp_options)
    show(f"surrogate={args.surrogate}", rows)
    cold, warm = rows[0]["ask"], float(np.median([r["ask"] for r in rows[1:]] or [np.nan]))
    warm_cpu = float(np.median([r["cpu_ask"] for r in rows[1:]] or [np.nan]))
    print(f"\nper iteration (ask = fit + 20 generations + choice): cold {cold:.2f} s, "
          f"warm median {warm:.2f} s wall / {warm_cpu:.2f} s CPU; cold/warm = {cold / warm:.2f}")
    if args.reference == "free" and args.surrogate != "free":
        ref = bench("free", args.n, args.iters, args.stage, args.seed)
        show("reference: zero-cost stand-in model (EA machinery only)", ref)
        ea = float(np.median([r["ask"] for r in ref]))
        print(f"\nEA machinery alone: {ea:.2f} s per iteration; surrogate share of the warm "
              f"iteration: {(warm - ea) / warm:.0%}; ratio warm/EA-only = {warm / ea:.1f}")
    print(f"load average at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
