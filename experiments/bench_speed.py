"""Speed where the time goes (issue 19): qLogNEHVI, the GP-assisted MGSAEA iteration, the
simulator for designs x noise seeds; each against a reference run in the same process.

Usage::

    python experiments/bench_speed.py --quick      # <= 5 min on 2 shared cores
    python experiments/bench_speed.py              # full: several archive sizes, per-run
                                                   # estimates (long: ~1 h of one core)
    python experiments/bench_speed.py --section qlognehvi --sizes 300 500 --profile

Sections (every time is process CPU seconds of one thread, the load-robust proxy for the
wall time of an idle machine; wall seconds and the load average are printed beside):

* ``qlognehvi``: per-iteration cost (``ask``: GP fit + qLogNEHVI maximisation) of the
  default settings (tmopt/conf/algorithm/qlognehvi.yaml) against the reference
  (tmopt/conf/algorithm/qlognehvi_reference.yaml, the settings before this work, which
  reproduce its archives bit for bit), both built from their YAML like the CLI does, on
  the same archive of the stiffness problem (scheme B, k = 3: D = 18, 2 objectives, 4
  constraints; designs of an MGSAEA-IPC/RBF run, seed 0). At every size n the GPs are
  first fitted on the first n - 5 designs (the previous iteration's fit a run warm-starts
  from, untimed); then the reference runs one iteration and the default settings run one
  full refit cycle (``refit_every`` iterations: kept hyperparameters, then a re-fit), so
  both means are per-iteration averages of a run's steady state. The full mode also
  times the capped reference of docs/results.md's Table 3 (``max_baseline=64``) and turns
  the per-iteration costs into a per-run estimate (piecewise-linear over the run's sizes).
  ``--profile`` prints where the time goes (docs/speed.md's profile tables).
* ``gp``: one MGSAEA-IPC iteration with the GP at 300 points, D = 18
  (experiments/bench_mgsaea_iteration.py's setting), tmopt/conf/surrogate/gp.yaml's defaults
  against re-optimising the hyperparameters at every fit (``refit_every=1``, no guard,
  the setting before this work); means over warm iterations (the default's over one
  refit cycle).
* ``sim``: CPU ms per (design, noise seed) of the closed-loop simulator, B = 100 designs
  of the stiffness problem x K = 32 noise seeds (8 in ``--quick``), in runs of the
  problem's chunk per call: the current kernel against today's
  (``REFERENCE_KERNEL_COMMIT``, read from git and compiled in this process), with one
  numba thread and with all; every kernel output (theta_hat, summary, status) is compared
  bit for bit, and so is everything the problem reads (convergence time, accuracies, M,
  Eq. 20's constraint values, divergence) for the B designs x K seeds.

The last line is ``speed: qlognehvi_ratio=R1 gp_iter_ratio=R2 sim_ms_per_design_seed=T
sim_ratio=R3`` (ratios = reference time / new time, in this process). In ``--quick`` R1
is the per-iteration ratio at 300 designs; the full mode's is the per-run estimate of the
Table 3 run (697 evaluations) against the uncapped reference.
"""

from __future__ import annotations

import argparse
import cProfile
import inspect
import json
import os
import pstats
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

SECTIONS = ("qlognehvi", "gp", "sim")
#: Functions whose cumulative time makes the qLogNEHVI profile table (label, name).
PROFILE_ROWS = (
    ("GP fit (hyperparameters or kept)", "fit", "gp.py"),
    ("baseline pruning", "prune_inferior_points_multi_objective", "utils.py"),
    ("acquisition set-up (box decompositions)", "__init__", "hypervolume.py"),
    ("pending points (box decompositions)", "set_X_pending", "hypervolume.py"),
    ("raw samples (restart choice)", "gen_batch_initial_conditions", "initializers.py"),
    ("L-BFGS-B on the acquisition", "gen_candidates_scipy", "gen.py"),
    ("  of which: joint posterior (forward)", "posterior", None),
    ("  of which: backward (gradients)", "run_backward", None),
)


#: L-BFGS-B cap of the untimed fit before the timed iterations: the hyperparameters a run
#: has warm-started through dozens of fits by then are near an optimum, not 50 steps from
#: BoTorch's initial values.
PREVIOUS_FIT_MAX_ITER = 200


def load() -> str:
    return f"load average {os.getloadavg()[0]:.2f}"


class Clock:
    """Process CPU and wall seconds of a block."""

    def __enter__(self):
        self.c, self.w = time.process_time(), time.perf_counter()
        return self

    def __exit__(self, *exc):
        self.cpu, self.wall = time.process_time() - self.c, time.perf_counter() - self.w


# ---- qLogNEHVI --------------------------------------------------------------------------
def algorithm_from_yaml(name: str, **overrides):
    """tmopt/conf/algorithm/<name>.yaml built as the CLI builds it (plus overrides)."""
    from tmopt.run.build import build_algorithm
    from tmopt.run.cli import option_config

    node = option_config("algorithm", name)
    for key, value in overrides.items():
        node[key] = value
    return build_algorithm(OmegaConf.create({"algorithm": node}), name)


def stiffness_archive(n: int, path: Path | None = None):
    """The stiffness problem (scheme B, k = 3) and an archive of at least n designs: the
    ``archive.h5`` at ``path`` (a run of this problem), else the designs of an MGSAEA-IPC
    run with the RBF surrogate (seed 0), cheap to make. The second is conservative for
    qLogNEHVI's reference: few of its designs are likely Pareto optimal (~12 in the pruned
    baseline at 500 designs, against ~200 in qLogNEHVI's own runs), and the reference's
    cost grows with that number."""
    from tmopt.algorithms.mgsaea import MGSAEAIPC
    from tmopt.evaluation.archive import read_archive
    from tmopt.problems.stiffness import StiffnessProblem
    from tmopt.run.runner import run_optimisation
    from tmopt.surrogates.rbf import RBFSurrogate

    problem = StiffnessProblem()
    if path is not None:
        data = read_archive(path)
        config = path.parent / "config.yaml"
        if config.exists():  # the run's own problem (e.g. noise=information, Table 3)
            from tmopt.run.build import build_problem

            problem = build_problem(OmegaConf.load(config))
        if data.X.shape[1] != problem.n_var or len(data.X) < n:
            sys.exit(f"bench_speed: --archive {path} must hold >= {n} designs of the "
                     f"stiffness problem (scheme B, k = 3: {problem.n_var} variables), "
                     f"got {data.X.shape}")
        return problem, data
    res = run_optimisation(problem, MGSAEAIPC(surrogate=RBFSurrogate, max_iter=None),
                           budget=max(n, 202), seed=0, progress=False, plots=False)
    return problem, res.archive


def warm_up_botorch() -> None:
    """Load (or, the first time on a machine, compile) BoTorch's fused qLogEHVI kernel
    before any timing: a one-off per process, not a cost of either variant."""
    from botorch.acquisition.multi_objective import logei

    logei._try_load_fused_kernel()


def time_qlognehvi(name: str, problem, data, n: int, iters: int, profile: bool = False,
                   **overrides) -> dict:
    """Per-iteration CPU/wall of ``ask`` at archive size n (see the module docstring)."""
    from tmopt.evaluation.evaluator import EvaluatedBatch, Evaluator

    alg = algorithm_from_yaml(name, **overrides)
    alg.setup(problem, budget=n + 5 * iters + 5, seed=0)

    def tell(lo, hi):
        alg.tell(EvaluatedBatch(X=data.X[lo:hi], F=data.F[lo:hi], G=data.G[lo:hi],
                                failed=data.failed[lo:hi], reason=[""] * (hi - lo)))

    tell(0, n - 5)
    Y, _ = alg._training_targets()
    cap, alg.gp.max_iter = alg.gp.max_iter, max(alg.gp.max_iter, PREVIOUS_FIT_MAX_ITER)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alg.gp.fit(alg.U, Y)  # the previous iteration's fit, the warm start of the next
    alg.gp.max_iter = cap
    tell(n - 5, n)
    alg.iteration = 1
    ev = Evaluator(problem, 10**9)
    rows, prof = [], cProfile.Profile() if profile else None
    for _ in range(iters):
        with Clock() as c:
            if prof:
                prof.enable()
            X = alg.ask()
            if prof:
                prof.disable()
        with Clock() as sim:  # the q designs' evaluation (simulator), outside the profile
            batch = ev.evaluate(X)
        rows.append({"cpu": c.cpu, "wall": c.wall, "stage": alg.gp.fit_info.get("stage"),
                     "sim_cpu": sim.cpu, "sim_wall": sim.wall,
                     **{k: round(v, 2) for k, v in alg.timing.items()}})
        alg.tell(batch)
    out = {"cpu": float(np.mean([r["cpu"] for r in rows])),
           "wall": float(np.mean([r["wall"] for r in rows])), "rows": rows,
           "sim_cpu": float(np.mean([r["sim_cpu"] for r in rows]))}
    if prof:
        out["profile"] = profile_table(prof, iters)
        out["profile"]["simulator (q designs evaluated; CPU s)"] = out["sim_cpu"]
    return out


def profile_table(prof: cProfile.Profile, iters: int) -> dict[str, float]:
    """Cumulative seconds per iteration of the PROFILE_ROWS functions (wall, profiled)."""
    stats = pstats.Stats(prof).stats  # {(file, line, func): (cc, nc, tt, ct, callers)}
    out = {"total": max(v[3] for v in stats.values()) / iters}
    for label, func, file in PROFILE_ROWS:
        hits = [v for (f, _, name), v in stats.items()
                if (name == func or (file is None and func in name))
                and (file is None or f.endswith(file))]
        out[label] = max((v[3] for v in hits), default=0.0) / iters
    top = [lb for lb, _, _ in PROFILE_ROWS if not lb.startswith(" ")]
    out["other (total - the rows above)"] = out["total"] - sum(out[lb] for lb in top)
    return out


def guard_fit_quality(problem, data, sizes, caps) -> None:
    """What capping a guard-triggered re-fit costs the GPs (``gp_guard_max_iter``): at each
    size n, the GPs are fitted on the first n - 5 designs (PREVIOUS_FIT_MAX_ITER, the
    previous optimum), then the guard re-fits them on n designs with each cap; printed:
    CPU s, the L-BFGS-B iterations, the optimised objective (negative log marginal
    likelihood + priors, per data point, summed over the outputs; lower is better) and
    the mean negative log predictive density (NLPD) and RMSE of the next 25 designs of the
    archive (the ones the run's acquisition chose next), targets as the algorithm scales
    them, a predictive std floor of 1e-3 of the output's spread."""
    import copy

    import tmopt.surrogates.gp as gpmod
    from tmopt.evaluation.evaluator import EvaluatedBatch
    from tmopt.surrogates.gp import GPSurrogate

    fvals: list[float] = []
    scipy_fit = gpmod.fit_gpytorch_mll_scipy

    def recording(mll, **kwargs):
        result = scipy_fit(mll, **kwargs)
        fvals.append(float(result.fval))
        return result

    print("\nGuard-triggered GP re-fit, capped (gp_guard_max_iter): CPU s, objective, "
          "prediction of the next 25 designs\n")
    print("| n | cap | CPU s | L-BFGS-B iterations per output | -log ML / n (sum) | "
          "NLPD next 25 | RMSE / std next 25 |")
    print("|---|---|---|---|---|---|---|")
    gpmod.fit_gpytorch_mll_scipy = recording
    try:
        for n in sizes:
            alg = algorithm_from_yaml("qlognehvi")
            alg.setup(problem, budget=n + 30, seed=0)
            alg.tell(EvaluatedBatch(X=data.X[:n + 25], F=data.F[:n + 25], G=data.G[:n + 25],
                                    failed=data.failed[:n + 25], reason=[""] * (n + 25)))
            Y, _ = alg._training_targets()
            U = alg.U
            base = GPSurrogate(max_iter=PREVIOUS_FIT_MAX_ITER, refit_every=5,
                               refit_guard=1e-12, rbf_fallback=False)  # the guard always fires
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                base.fit(U[:n - 5], Y[:n - 5])
                for cap in caps:
                    gp = copy.deepcopy(base)
                    gp.max_iter, gp.guard_max_iter = alg.gp_max_iter, cap
                    fvals.clear()
                    with Clock() as c:
                        gp.fit(U[:n], Y[:n])
                    mean, std = gp.predict(U[n:n + 25])
                    y, spread = Y[n:n + 25], Y[:n].std(axis=0)
                    spread = np.where(spread > 0, spread, 1.0)  # a constant output
                    s = np.sqrt(std ** 2 + (1e-3 * spread) ** 2)
                    nlpd = 0.5 * np.log(2 * np.pi * s ** 2) + 0.5 * ((y - mean) / s) ** 2
                    rmse = np.sqrt(((y - mean) ** 2).mean(axis=0)) / spread
                    print(f"| {n} | {cap} | {c.cpu:.1f} | {gp.fit_info['iterations']} | "
                          f"{sum(fvals):.4f} | {nlpd.mean():.3f} | {rmse.mean():.3f} |",
                          flush=True)
    finally:
        gpmod.fit_gpytorch_mll_scipy = scipy_fit


def acquisition_settings(problem, data, sizes, settings: list[str], seeds: int = 2,
                         judge_samples: int = 1024) -> None:
    """What the acquisition's settings cost and buy (docs/speed.md, job "acquisition"): at
    each size n, the default settings' GPs (max_baseline=64) fitted on the first n designs
    (PREVIOUS_FIT_MAX_ITER, the near-optimum a run has warm-started through), then one
    acquisition of q designs per setting (the defaults, then each ``key=value[,key=value]``
    override of QLogNEHVI's constructor) and seed: its CPU s, and the chosen batch's joint
    qLogNEHVI under one judge (``judge_samples`` Sobol samples, the defaults' pruned
    baseline), as log(EHVI) minus the defaults' (0 = as good, -0.1 = 10 % less expected
    hypervolume improvement), averaged over the seeds."""
    import torch

    from tmopt.evaluation.evaluator import EvaluatedBatch
    from tmopt.surrogates.gp_posterior import CachedJointGP

    parsed = {"defaults": {}}
    for text in settings:
        parsed[text] = {k: _scalar(v) for k, v in (item.split("=", 1)
                                                    for item in text.split(","))}
    print(f"\nAcquisition settings at a fitted GP (defaults, max_baseline=64; {seeds} seeds; "
          f"judge: {judge_samples} MC samples); {load()}\n")
    print("| n | setting | CPU s | ratio to defaults | log EHVI - defaults' (mean; min) |")
    print("|---|---|---|---|---|")
    for n in sizes:
        alg = algorithm_from_yaml("qlognehvi", max_baseline=64)
        alg.setup(problem, budget=n + 5, seed=0)
        alg.tell(EvaluatedBatch(X=data.X[:n], F=data.F[:n], G=data.G[:n],
                                failed=data.failed[:n], reason=[""] * n))
        Y, ref = alg._training_targets()
        alg.gp.max_iter = PREVIOUS_FIT_MAX_ITER
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            alg.gp.fit(alg.U, Y)
            with torch.random.fork_rng():
                torch.manual_seed(0)
                judge = alg.acquisition(CachedJointGP(alg.gp), ref, 0, judge_samples)
        defaults = {k: getattr(alg, k) for k in {k for o in parsed.values() for k in o}}
        base_cpu, base_value = None, None
        for label, over in parsed.items():
            for k, v in {**defaults, **over}.items():
                setattr(alg, k, v)
            cpu, values = [], []
            for seed in range(seeds):
                with Clock() as c:
                    X = alg._maximise(ref, 1000 + seed)
                cpu.append(c.cpu)
                with torch.no_grad():
                    values.append(float(judge(torch.as_tensor(X)[None])))
            cpu_mean, values = float(np.mean(cpu)), np.array(values)
            if base_cpu is None:
                base_cpu, base_value = cpu_mean, values
            d = values - base_value
            print(f"| {n} | {label} | {cpu_mean:.2f} | {base_cpu / cpu_mean:.2f} | "
                  f"{d.mean():+.3f}; {d.min():+.3f} |", flush=True)


def _scalar(text: str):
    """A command-line value as YAML reads it, ``1e-4`` (YAML 1.1: a string) as a float."""
    import yaml

    value = yaml.safe_load(text)
    try:
        return float(value) if isinstance(value, str) else value
    except ValueError:
        return value


def acquisition_call_ms(problem, data, n: int) -> dict[str, float]:
    """CPU ms of one qLogNEHVI evaluation (value + gradient, 4 restarts) and of scoring
    256 raw samples, through GPyTorch and through CachedJointGP, on the same acquisition
    (the default's pruned baseline at n designs)."""
    import torch
    from botorch.acquisition.multi_objective.logei import (
        qLogNoisyExpectedHypervolumeImprovement as QLogNEHVI,
    )
    from botorch.acquisition.multi_objective.objective import IdentityMCMultiOutputObjective
    from botorch.acquisition.multi_objective.utils import (
        prune_inferior_points_multi_objective,
    )
    from botorch.sampling import SobolQMCNormalSampler

    from tmopt.evaluation.evaluator import EvaluatedBatch
    from tmopt.surrogates.gp_posterior import CachedJointGP

    alg = algorithm_from_yaml("qlognehvi")
    alg.setup(problem, budget=n + 5, seed=0)
    alg.tell(EvaluatedBatch(X=data.X[:n], F=data.F[:n], G=data.G[:n],
                            failed=data.failed[:n], reason=[""] * n))
    Y, ref = alg._training_targets()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alg.gp.fit(alg.U, Y)
    m, k = problem.n_obj, problem.n_ieq_constr
    objective = IdentityMCMultiOutputObjective(outcomes=list(range(m)))
    constraints = [lambda Z, j=j: Z[..., m + j] for j in range(k)]
    torch.manual_seed(0)
    baseline = prune_inferior_points_multi_objective(
        alg.gp.model, torch.as_tensor(alg.U), ref_point=torch.as_tensor(ref),
        objective=objective, constraints=constraints)
    X4 = torch.rand(4, 1, problem.n_var, dtype=torch.float64, requires_grad=True)
    X256 = torch.rand(256, 1, problem.n_var, dtype=torch.float64)
    out = {"baseline": len(baseline)}
    for label, model in (("gpytorch", alg.gp.model), ("cached", CachedJointGP(alg.gp))):
        acq = QLogNEHVI(model=model, ref_point=ref.tolist(), X_baseline=baseline,
                        sampler=SobolQMCNormalSampler(torch.Size([64]), seed=0),
                        objective=objective, constraints=constraints, prune_baseline=False)
        with Clock() as c:
            for _ in range(5):
                torch.autograd.grad(acq(X4).sum(), X4)
        out[f"{label} f+g"] = 1e3 * c.cpu / 5
        with Clock() as c, torch.no_grad():
            acq(X256)
        out[f"{label} raw"] = 1e3 * c.cpu
    return out


def section_qlognehvi(sizes, quick: bool, profile: bool, archive: Path | None = None,
                      variants: list[str] | None = None, iters: int | None = None,
                      new_settings: dict | None = None) -> float:
    import logging

    logging.getLogger("tmopt.algorithms.qlognehvi").setLevel(logging.ERROR)  # no run notice
    warm_up_botorch()
    with Clock() as c:
        problem, data = stiffness_archive(max(sizes), archive)
    source = archive or f"MGSAEA-IPC/RBF run, made in {c.cpu:.1f} s CPU"
    print(f"\n## qLogNEHVI per iteration, stiffness problem (scheme B, k = 3, D = 18); "
          f"archive: {source}; {load()}\n")
    every = {"new": ("qlognehvi", {}), "reference": ("qlognehvi_reference", {}),
             "reference, max_baseline=64": ("qlognehvi_reference", {"max_baseline": 64}),
             "new, max_baseline=64": ("qlognehvi", {"max_baseline": 64})}
    variants = {k: every[k] for k in (variants or list(every)[:2 if quick else 3])}
    cycle = algorithm_from_yaml("qlognehvi").refit_every
    per: dict[str, dict[int, dict]] = {v: {} for v in variants}
    print("| n | variant | iterations | CPU s / iteration | wall s | per-iteration stages |")
    print("|---|---|---|---|---|---|")
    for n in sizes:
        for label, (name, over) in variants.items():
            k = (iters or cycle) if label.startswith("new") else 1
            if label.startswith("new"):  # --new-settings: the defaults' overrides
                over = {**over, **(new_settings or {})}
            r = time_qlognehvi(name, problem, data, n, k, profile, **over)
            per[label][n] = r
            stages = ", ".join(f"{x['stage']} {x['cpu']:.1f}" for x in r["rows"])
            print(f"| {n} | {label} | {k} | {r['cpu']:.2f} | {r['wall']:.2f} | {stages} |",
                  flush=True)
    if profile:
        print_profiles(per, sizes)
        print("\nOne acquisition evaluation, CPU ms (value + gradient at 4 points; value at 256 "
              "raw samples), the same acquisition through GPyTorch and CachedJointGP:\n")
        print("| n | baseline | GPyTorch f+g | cached f+g | ratio | GPyTorch 256 raw | "
              "cached 256 raw | ratio |")
        print("|---|---|---|---|---|---|---|---|")
        for n in sizes:
            a = acquisition_call_ms(problem, data, n)
            print(f"| {n} | {a['baseline']} | {a['gpytorch f+g']:.1f} | {a['cached f+g']:.1f} "
                  f"| {a['gpytorch f+g'] / a['cached f+g']:.1f} | {a['gpytorch raw']:.0f} | "
                  f"{a['cached raw']:.0f} | {a['gpytorch raw'] / a['cached raw']:.1f} |")
    pairs = [(r, v) for r, v in (("reference", "new"),
                                 ("reference, max_baseline=64", "new, max_baseline=64"))
             if r in per and v in per]
    if not pairs:
        return float("nan")
    for ref, new in pairs:
        ratios = {n: per[ref][n]["cpu"] / per[new][n]["cpu"] for n in sizes}
        print(f"\nper-iteration ratio {ref} / {new}: "
              + ", ".join(f"n={n}: {r:.1f}" for n, r in ratios.items()))
    ref, new = pairs[0]
    if quick or len(sizes) < 2:
        return ratios[max(sizes)] if len(pairs) == 1 else \
            per[ref][max(sizes)]["cpu"] / per[new][max(sizes)]["cpu"]
    runs = {label: per_run(problem, {n: per[label][n]["cpu"] for n in sizes})
            for label in variants}
    for label, seconds in runs.items():
        print(f"per-run estimate ({label}): {seconds / 60:.1f} min CPU for 697 evaluations")
    for r, v in pairs:
        print(f"per-run ratio: {r} / {v} = {runs[r] / runs[v]:.1f}")
    if "reference, max_baseline=64" in runs and "new" in runs:
        print(f"per-run ratio: capped reference (Table 3) / new = "
              f"{runs['reference, max_baseline=64'] / runs['new']:.1f}")
    return runs[ref] / runs[new]


def per_run(problem, cpu_at: dict[int, float], budget: int = 697, q: int = 5) -> float:
    """CPU seconds of a run's BO iterations: per-iteration cost interpolated linearly
    between the measured sizes (constant beyond them) at n = n_init, n_init + q, ..."""
    n_init = 2 * (problem.n_var + 1)
    sizes = np.arange(n_init, budget, q)
    xs = sorted(cpu_at)
    return float(np.interp(sizes, xs, [cpu_at[x] for x in xs]).sum())


#: A progress line of a qLogNEHVI run: designs so far, the fit's stage and guard statistic.
_PROGRESS = r"evals (\d+)/\d+ .*iteration=\d+ fit=[\d.]+s acq=[\d.]+s gp=(\w+)( surprise=([\d.]+))?"


def run_cost_from_log(log: Path, costs: dict, guard: float = 4.0) -> None:
    """CPU minutes of a whole qLogNEHVI run from per-iteration costs and the run's own
    stage sequence (docs/speed.md, "Per run in the Table 3 setting").

    Every iteration of the run's ``tmopt.log`` gives its number of designs n and its fit
    stage: kept, re-fitted because the guard fired (surprise > ``guard``), or re-fitted by
    the schedule. Its cost = ``acq(n)`` + the stage's fit cost at n (``kept``, ``fit50``
    for a full re-fit, ``fit10`` for a capped guard re-fit after gp_guard_max_iter), each
    interpolated linearly between the measured sizes (constant outside); the reference's
    ``ref(n)`` likewise. ``costs``: {key: {n: CPU s}} for acq, kept, fit50, fit10, ref.
    """
    import re

    stages = []
    for line in log.read_text().splitlines():
        m = re.search(_PROGRESS, line)
        if m:
            surprise = None if m[4] is None else float(m[4])
            kind = "kept" if m[2] == "kept_hypers" else (
                "guard" if surprise is not None and surprise > guard else "scheduled")
            stages.append((int(m[1]) - 5, kind))  # the fit saw the designs before its batch

    def at(key: str, n: int) -> float:
        xs = sorted(int(x) for x in costs[key])
        return float(np.interp(n, xs, [costs[key][str(x)] for x in xs]))

    fit = {"before": {"kept": "kept", "guard": "fit50", "scheduled": "fit50"},
           "after": {"kept": "kept", "guard": "fit10", "scheduled": "fit50"}}
    total = {v: sum(at("acq", n) + at(fit[v][k], n) for n, k in stages) for v in fit}
    total["reference"] = sum(at("ref", n) for n, _ in stages)
    counts = {k: sum(1 for _, s in stages if s == k) for k in ("kept", "guard", "scheduled")}
    print(f"\n{len(stages)} iterations ({counts}); CPU min per run: "
          + ", ".join(f"{v} {t / 60:.1f}" for v, t in total.items()))
    print(f"R1 per run: reference / before = {total['reference'] / total['before']:.1f}, "
          f"reference / after = {total['reference'] / total['after']:.1f}")


def print_profiles(per: dict, sizes) -> None:
    print("\nWhere an iteration's time goes (cProfile, wall seconds per iteration, "
          "cumulative; nested rows overlap):\n")
    cols = [(label, n) for n in sizes for label in per]
    print("| part | " + " | ".join(f"{lb} n={n}" for lb, n in cols) + " |")
    print("|---|" + "---|" * len(cols))
    rows = ("total", *(lb for lb, _, _ in PROFILE_ROWS), "other (total - the rows above)",
            "simulator (q designs evaluated; CPU s)")
    for row in rows:
        print(f"| {row} | " + " | ".join(f"{per[lb][n]['profile'][row]:.2f}"
                                         for lb, n in cols) + " |")


# ---- GP-assisted MGSAEA iteration --------------------------------------------------------
def section_gp(quick: bool) -> float:
    from bench_mgsaea_iteration import bench

    from tmopt.surrogates.gp import GPSurrogate

    cycle = GPSurrogate().refit_every
    print(f"\n## MGSAEA-IPC iteration with the GP, n = 300, D = 18 (stage one, 3 models); "
          f"{load()}\n")
    reference = {"refit_every": 1, "refit_guard": None}
    warm = {}
    for label, options, iters in (("reference", reference, 3 if quick else 6),
                                  ("new", {}, cycle if quick else 2 * cycle)):
        rows = bench("gp", 300, iters + 1, 1, 0, options)
        cpu = [r["cpu_ask"] for r in rows[1:]]
        warm[label] = float(np.mean(cpu))
        print(f"{label:9s} ({options or 'tmopt/conf/surrogate/gp.yaml defaults'}): cold "
              f"{rows[0]['cpu_ask']:.2f} s, warm {', '.join(f'{c:.2f}' for c in cpu)} s CPU; "
              f"mean {warm[label]:.2f} s", flush=True)
    ratio = warm["reference"] / warm["new"]
    print(f"per-iteration ratio reference / new: {ratio:.2f}")
    return ratio


# ---- simulator for designs x noise seeds -------------------------------------------------
#: The closed-loop kernel before issue 19's changes (the reference of ``sim``), read from
#: git: the commit whose tmopt/physics/_closed_loop.py was today's kernel.
REFERENCE_KERNEL_COMMIT = "fe4e367"


def reference_kernel_module():
    """Today's kernel (``REFERENCE_KERNEL_COMMIT``) as a module of its own, compiled in this
    process beside the current one; None (with the reason printed) without git history."""
    import importlib.util
    import subprocess
    import tempfile

    try:
        source = subprocess.run(
            ["git", "-C", str(REPO), "show",
             f"{REFERENCE_KERNEL_COMMIT}:tmopt/physics/_closed_loop.py"],
            capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as err:
        print(f"no reference kernel (git show {REFERENCE_KERNEL_COMMIT} failed: {err}); "
              f"sim_ratio is nan")
        return None
    # a fixed file per commit, written once, so numba's cache of it holds across runs
    path = Path(tempfile.gettempdir()) / f"tmopt_kernel_{REFERENCE_KERNEL_COMMIT}" \
        / "_closed_loop_reference.py"
    if not path.exists() or path.read_text() != source:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(source)
    spec = importlib.util.spec_from_file_location("_closed_loop_reference", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # numba's cache finds the module by its name
    spec.loader.exec_module(module)
    return module


#: the kernel outputs of a run in estimates mode (what SimulationResult is made of)
KERNEL_OUTPUTS = ("out_th", "summary", "status")


def run_kernel(kernel, ref1, ref2, cfg, seeds, outputs: bool = False):
    """Runs (ref1[i], ref2[i], seeds[i]) through ``kernel`` with the simulator's own inputs;
    theta_hat (B, N, 5), or with ``outputs`` the dict of KERNEL_OUTPUTS. A kernel that
    takes one noise realisation per launch (before issue 18's ``noise_of``) is launched
    once per seed; the inputs are passed by the kernel's own parameter names (a kernel
    before the y set points has no ``refy``)."""
    from tmopt.physics import simulator as S

    params = inspect.signature(kernel.py_func).parameters  # a kernel's own arguments
    if "noise_of" in params:
        io = S.prepare(ref1, ref2, cfg, seeds)
        kernel(*[io[k] for k in params])
        return {k: io[k] for k in KERNEL_OUTPUTS} if outputs else io["out_th"]
    out = {"out_th": np.empty((len(seeds), ref1.shape[1], 5)),
           "summary": np.empty((len(seeds), 12)), "status": np.empty((len(seeds), 2), int)}
    for seed in np.unique(seeds):
        rows = np.flatnonzero(seeds == seed)
        io = S.prepare(ref1[rows], ref2[rows], cfg, int(seed))
        io["noise"] = io["noise"].reshape(-1, *io["noise"].shape[-2:])[0]  # (14, N)
        kernel(*[io[k] for k in params if k != "noise_of"])
        for k in KERNEL_OUTPUTS:
            out[k][rows] = io[k]
    return out if outputs else out["out_th"]


def problem_outputs(problem, X: np.ndarray, seeds: np.ndarray, kernel=None) -> dict:
    """Everything the stiffness problem reads from the simulator for designs X x seeds,
    (n, K) arrays: convergence time, accuracies, M (and its stricter-epsilon variants) per
    objective test mass, Eq. 20's constraint values and feasibility (the held-out scoring's
    ``_run_scores``), computed with ``kernel`` (a batch kernel without ``lanes``, e.g. the
    reference) in place of the simulator's own when given."""
    from tmopt.physics import _closed_loop as cl
    from tmopt.physics import objectives as phys_obj
    from tmopt.physics import simulator as S
    from tmopt.problems.heldout import _run_scores

    current = cl.batch_kernel
    if kernel is not None:  # the simulator's call, by the kernel's own parameter names
        own = inspect.signature(kernel.py_func).parameters
        cl.batch_kernel = lambda *args: kernel(
            *[a for name, a in zip(S._KERNEL_ARGS, args) if name in own])
    try:
        n, k = len(X), len(seeds)
        out: dict[str, list] = {}
        step = max(1, problem.chunk // k)
        for start in range(0, n, step):
            block = X[start:start + step]
            res = problem.simulate_designs(np.repeat(block, k, axis=0),
                                           seed=np.tile(seeds, len(block)))
            cols = _run_scores(problem, res)
            g = problem._normalised(phys_obj.eq20_realised(res))
            for j in range(g.shape[1]):
                cols[f"constraint_{j}"] = g[:, j]
            cols["diverged"] = res.diverged
            for key, v in cols.items():
                out.setdefault(key, []).append(np.asarray(v).reshape(len(block), k))
    finally:
        cl.batch_kernel = current
    return {key: np.vstack(v) for key, v in out.items()}


def compare_outputs(new: dict, ref: dict) -> tuple[bool, str]:
    """(all bit-identical, a line naming every output and its largest difference)."""
    same, parts = True, []
    for key in new:
        a, b = np.asarray(new[key], float), np.asarray(ref[key], float)
        eq = np.array_equal(a, b, equal_nan=True)
        same &= eq
        diff = np.nanmax(np.abs(a - b)) if not eq else 0.0
        parts.append(f"{key} {'=' if eq else f'max|diff| {diff:.3g}'}")
    return same, "; ".join(parts)


def section_sim(quick: bool) -> tuple[float, float]:
    """ms per (design, seed): B = 100 designs of the stiffness problem x K noise seeds, in
    runs of the problem's chunk per call, the current kernel against today's; the same
    inputs (prepared by the simulator) for both, outputs compared bit for bit."""
    from dataclasses import replace

    import numba

    from tmopt.physics import _closed_loop as cl
    from tmopt.physics.simulator import sample_times
    from tmopt.problems.stiffness import StiffnessProblem

    reference = reference_kernel_module()
    problem = StiffnessProblem()
    cfg = problem.config
    b, k = 100, (8 if quick else 32)
    chunk = getattr(problem, "chunk", 100)
    rng = np.random.default_rng(0)
    X = problem.xl + rng.random((b, problem.n_var)) * (problem.xu - problem.xl)
    t = sample_times(cfg.duration, cfg.sample_rate)
    refs = [r.evaluate(t) for r in problem.references(X)]  # (B, N) each, before the ramp
    rows = np.repeat(np.arange(b), k)  # design of every run
    seeds = np.tile(np.arange(k, dtype=np.int64), b)
    kernels = {"new": cl.batch_kernel}
    if reference is not None:
        kernels["reference"] = reference.batch_kernel
    for kernel in kernels.values():  # compile / cache load, untimed
        run_kernel(kernel, refs[0][:1], refs[1][:1], cfg, seeds[:1])
    print(f"\n## Simulator: B = {b} designs x K = {k} seeds of the stiffness problem "
          f"({cfg.controller}, {t.size} steps), {chunk} runs per call; {load()}\n")
    print("| threads | kernel | CPU ms per (design, seed) | wall ms | ratio reference / new |")
    print("|---|---|---|---|---|")
    threads_all = numba.get_num_threads()
    result = (float("nan"), float("nan"))
    for threads in sorted({1, threads_all}):
        numba.set_num_threads(threads)
        clocks = {name: [0.0, 0.0] for name in kernels}
        same, diverged = True, 0
        for start in range(0, b * k, chunk):
            sl = slice(start, start + chunk)
            outs = {}
            for name, kernel in kernels.items():
                with Clock() as c:
                    outs[name] = run_kernel(kernel, refs[0][rows[sl]], refs[1][rows[sl]], cfg,
                                            seeds[sl], outputs=True)
                clocks[name][0] += c.cpu
                clocks[name][1] += c.wall
            if "reference" in outs:
                same &= compare_outputs(outs["new"], outs["reference"])[0]
                diverged += int(np.sum(outs["new"]["status"][:, 0] != 0))
        ms = {name: [1e3 * v / (b * k) for v in cw] for name, cw in clocks.items()}
        ratio = ms["reference"][0] / ms["new"][0] if "reference" in ms else float("nan")
        for name in kernels:
            print(f"| {threads} | {name} | {ms[name][0]:.2f} | {ms[name][1]:.2f} | "
                  f"{ratio:.2f} |" if name == "new" else
                  f"| {threads} | {name} | {ms[name][0]:.2f} | {ms[name][1]:.2f} | |")
        if "reference" in kernels:
            print(f"| {threads} | theta_hat, summary, status of every run bit-identical | "
                  f"{same} | | |")
            print(f"| {threads} | runs that diverged | {diverged} of {b * k} | | |")
        if threads == threads_all:
            result = (ms["new"][0], ratio)
        if threads == 1:  # where the time goes: the same runs with the plain PID
            pid = replace(cfg, controller="pid")
            with Clock() as c:
                for start in range(0, b * k, chunk):
                    sl = slice(start, start + chunk)
                    run_kernel(cl.batch_kernel, refs[0][rows[sl]], refs[1][rows[sl]], pid,
                               seeds[sl])
            print(f"| 1 | new, controller=pid (no FRBF network) | {1e3 * c.cpu / (b * k):.2f} "
                  f"| {1e3 * c.wall / (b * k):.2f} | |")
    numba.set_num_threads(threads_all)
    if reference is not None:  # what the problem reads, through the simulator's own path
        same, line = compare_outputs(problem_outputs(problem, X, np.arange(k)),
                                     problem_outputs(problem, X, np.arange(k),
                                                     reference.batch_kernel))
        print(f"\nproblem outputs of the {b} designs x {k} seeds, new vs reference kernel "
              f"(bit-identical: {same}): {line}")
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="<= 5 min: n = 300 only, fewer "
                    "iterations, K = 4 seeds")
    ap.add_argument("--section", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    ap.add_argument("--sizes", type=int, nargs="+", default=None,
                    help="qLogNEHVI archive sizes (default: 300 quick, else 100 300 500 697)")
    ap.add_argument("--profile", action="store_true", help="qLogNEHVI profile tables")
    ap.add_argument("--archive", type=Path, default=None,
                    help="archive.h5 of a stiffness run (scheme B, k = 3) to time qLogNEHVI "
                         "on, e.g. a qLogNEHVI run's; default: an MGSAEA-IPC/RBF run's")
    ap.add_argument("--variants", nargs="+", default=None,
                    choices=["new", "reference", "reference, max_baseline=64",
                             "new, max_baseline=64"],
                    help="qLogNEHVI variants to time (default: all the mode has)")
    ap.add_argument("--guard-fits", type=int, nargs="+", default=None, metavar="CAP",
                    help="instead of timing iterations: the guard-triggered GP re-fit with "
                         "these L-BFGS-B caps at each --sizes (needs --archive; "
                         "gp_guard_max_iter's evidence in docs/speed.md)")
    ap.add_argument("--run-cost", type=Path, nargs=2, default=None, metavar=("LOG", "COSTS"),
                    help="per-run CPU of a qLogNEHVI run from its tmopt.log's stages and a "
                         "JSON file of per-iteration costs (run_cost_from_log)")
    ap.add_argument("--acq-settings", nargs="+", default=None, metavar="KEY=VALUE[,...]",
                    help="instead of timing iterations: one acquisition per setting (the "
                         "defaults' overrides) at each --sizes, CPU and the batch's value "
                         "(needs --archive; acquisition_settings)")
    ap.add_argument("--new-settings", nargs="+", default=None, metavar="KEY=VALUE",
                    help="overrides of the defaults for the 'new' variants (e.g. "
                         "gp_guard_max_iter=5)")
    ap.add_argument("--acq-seeds", type=int, default=2,
                    help="acquisitions per setting and size for --acq-settings")
    ap.add_argument("--iters", type=int, default=None,
                    help="iterations of the default settings per size (default: one refit "
                         "cycle, refit_every); the reference variants run one")
    args = ap.parse_args()
    sizes = args.sizes or ([300] if args.quick else [100, 300, 500, 697])
    if min(sizes) < 50 or max(sizes) > 697:
        sys.exit(f"bench_speed: --sizes must be in [50, 697], got {sizes}")
    print(f"bench_speed ({'quick' if args.quick else 'full'}): {load()}, "
          f"cores {os.cpu_count()}")
    if args.run_cost:
        run_cost_from_log(args.run_cost[0], json.loads(args.run_cost[1].read_text()))
        return
    if args.guard_fits:
        problem, data = stiffness_archive(max(sizes) + 25, args.archive)
        guard_fit_quality(problem, data, sizes, args.guard_fits)
        return
    if args.acq_settings:
        problem, data = stiffness_archive(max(sizes), args.archive)
        acquisition_settings(problem, data, sizes, args.acq_settings, args.acq_seeds)
        return
    with Clock() as total:
        new_settings = {k: _scalar(v) for k, v in (x.split("=", 1)
                                                    for x in args.new_settings or [])}
        r1 = section_qlognehvi(sizes, args.quick, args.profile, args.archive, args.variants,
                               args.iters, new_settings) \
            if "qlognehvi" in args.section else float("nan")
        r2 = section_gp(args.quick) if "gp" in args.section else float("nan")
        t, r3 = section_sim(args.quick) if "sim" in args.section else (float("nan"),) * 2
    print(f"\ntotal {total.wall / 60:.1f} min wall, {total.cpu / 60:.1f} min CPU; {load()}")
    print(f"speed: qlognehvi_ratio={r1:.1f} gp_iter_ratio={r2:.2f} "
          f"sim_ms_per_design_seed={t:.2f} sim_ratio={r3:.2f}")


if __name__ == "__main__":
    main()
