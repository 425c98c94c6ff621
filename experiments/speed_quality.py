"""Quality of the fast settings against the reference ones (docs/speed.md, "Quality").

Runs the CLI sweeps of one study (sequentially, resumable: a finished run is skipped),
then scores every run and compares the two variants over the seeds with a two-sided
Wilcoxon rank-sum test:

* suite problems (MW3): IGD and HV of the final feasible front (the run's metrics.json);
* the stiffness problem: held-out M of the run's chosen design (Eq. 21), i.e. the design
  re-simulated on the problem's first 10 held-out noise realisations (never drawn by a
  search) and M (Eq. 29, default threshold) of TM1 averaged over them.

Usage::

    python experiments/speed_quality.py qlognehvi-mw3        # runs, then the table
    python experiments/speed_quality.py qlognehvi-stiffness --report-only
    python experiments/speed_quality.py --list

Cost (2 shared cores, one thread per run): see docs/speed.md; the reference variants
are the slow part (e.g. ~10 min of one core per MW3 run of 300 evaluations).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tmopt.reporting.stats import fmt_p, rank_sum  # noqa: E402

#: study -> (CLI overrides common to both variants, {variant: overrides}, metrics,
#: evaluations at which the variants are compared: None = the runs' ends)
STUDIES = {
    # The reference's iterations grow to 20-60 s of CPU at 300 designs, so it runs 200
    # evaluations and both are compared after their first 200 (a run's first 200
    # evaluations do not depend on its budget); the new runs go on to 300.
    "qlognehvi-mw3": (
        ["problem=mw3", "problem.n_var=10"],
        {"new": ["algorithm=qlognehvi", "budget=300"],
         "reference": ["algorithm=qlognehvi_reference", "budget=200"]},
        ("igd", "hv"), 200),
    "qlognehvi-stiffness": (
        ["problem=stiffness"],
        {"new": ["algorithm=qlognehvi", "budget=300"],
         "reference": ["algorithm=qlognehvi_reference", "budget=200"]},
        ("M_heldout",), 200),
    # The Table 3 setting (information mode, max_baseline=64), compared after 100
    # evaluations (what the shared machine allowed for the reference): the capped guard
    # re-fits (gp_guard_max_iter=10, opt-in) against the reference and against the
    # default ("before"; the Table 3 runs of docs/results.md were made with it).
    "qlognehvi-stiffness-info": (
        ["experiment=results", "problem.noise=information", "algorithm.max_baseline=64"],
        {"new": ["algorithm=qlognehvi", "algorithm.gp_guard_max_iter=10", "budget=100"],
         "before": ["algorithm=qlognehvi", "budget=100"],
         "reference": ["algorithm=qlognehvi_reference", "budget=100"]},
        ("M_heldout",), 100),
    # A suite problem where qLogNEHVI finds feasible designs within its first iterations
    # (MW3 at D = 6: 15-30 % of the designs feasible after 40 evaluations), small enough
    # for the reference to run to the end on 10 seeds: 14 initial designs + 10 iterations
    # (the reference's acquisition grows from ~5 s CPU per iteration at 50 designs to
    # ~40 s at 75 on a loaded core). The fast setting against the reference, paired by
    # seed (the same initial Sobol designs), with each run's CPU time (docs/speed.md).
    "qlognehvi-mw3-d6": (
        ["problem=mw3", "problem.n_var=6", "budget=64"],
        {"new": ["algorithm=qlognehvi", "algorithm.gp_guard_max_iter=5"],
         "cap10": ["algorithm=qlognehvi", "algorithm.gp_guard_max_iter=10"],
         "reference": ["algorithm=qlognehvi_reference"]},
        ("igd", "hv"), None),
    "gp-mw3": (
        ["problem=mw3", "problem.n_var=10", "algorithm=mgsaea_ipc", "surrogate=gp",
         "budget=609"],
        {"new": [], "reference": ["surrogate.refit_every=1", "surrogate.refit_guard=null"]},
        ("igd", "hv"), None),
    "gp-stiffness": (
        ["problem=stiffness", "algorithm=mgsaea_ipc", "surrogate=gp", "budget=697"],
        {"new": [], "reference": ["surrogate.refit_every=1", "surrogate.refit_guard=null"]},
        ("M_heldout",), None),
}
#: Held-out noise realisations per design (tmopt.physics.noise.heldout_seeds: never drawn
#: by a search).
HELDOUT_COUNT = 10
LOWER_IS_BETTER = {"igd": True, "hv": False, "M_heldout": True}


def run_sweep(study: str, seeds: list[int], out: Path, budget: int | None = None,
              only: list[str] | None = None) -> None:
    """Each variant's runs, one process per seed, seed by seed (resumable: a run with a
    complete metrics.json and its CPU record is skipped); each run's CPU seconds (the
    process and its children) go to its folder's ``cpu_s.json``."""
    common, variants, _, _ = STUDIES[study]
    if budget is not None:  # the first `budget` evaluations of a longer run, only cheaper
        variants = {v: [*o, f"budget={budget}"] for v, o in variants.items()}
    # BoTorch's fused qLogEHVI kernel is compiled into TORCH_EXTENSIONS_DIR; environments
    # sharing the default folder rebuild it in turn (~30 s CPU in a run's CPU time): one
    # folder per environment, built here before any run is timed (docs/speed.md).
    env = {"TORCH_EXTENSIONS_DIR": str(Path(sys.prefix) / "torch_extensions"), **os.environ,
           "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    subprocess.run([sys.executable, "-c", "from botorch.acquisition.multi_objective import "
                    "logei; logei._try_load_fused_kernel()"], env=env, check=True)
    for variant, overrides in variants.items():
        if only and variant not in only:
            continue
        for seed in seeds:
            run = out / study / variant / f"seed{seed}"
            if _complete(run) and (run / "cpu_s.json").exists():
                continue
            cmd = [sys.executable, "-m", "tmopt", "-m", *common, *overrides, f"seed={seed}",
                   "plots=false", f"hydra.sweep.dir={out / study / variant}",
                   "hydra.sweep.subdir=seed${seed}"]
            print("$", " ".join(cmd[1:]), flush=True)
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run(cmd, cwd=REPO, env=env, check=True)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
            (run / "cpu_s.json").write_text(json.dumps({"cpu_s": cpu}))


def _complete(run: Path) -> bool:
    path = run / "metrics.json"
    return path.exists() and json.loads(path.read_text()).get("status") == "complete"


def heldout_m(run: Path, x: np.ndarray) -> float:
    """Mean M_TM1 (default threshold) of design x over the first ``HELDOUT_COUNT``
    held-out noise seeds (the stiffness problem's own held-out scoring, issue 18)."""
    from tmopt.run.build import build_problem

    problem = build_problem(OmegaConf.load(run / ".hydra" / "config.yaml"))
    return float(np.mean(problem.heldout_report(x[None], n_seeds=HELDOUT_COUNT)["M_TM1"]))


def run_values(run: Path, metrics: dict, keys, at: int | None) -> dict | None:
    """The run's values at its end, or after its first ``at`` evaluations (None if the
    run has fewer): IGD/HV of the feasible front, held-out M of the chosen design."""
    from tmopt.evaluation.archive import read_archive
    from tmopt.run.build import build_problem
    from tmopt.run.outputs import final_choice, indicator_values, reference_front

    data = read_archive(run / "archive.h5")
    if at is not None:
        if len(data) < at:
            return None
        data = data.rows(0, at)
    pareto, best = final_choice(data)
    out = {"wall_time_s": metrics.get("wall_time_s") if at is None else None}
    if at is None and (run / "cpu_s.json").exists():
        out["cpu_s"] = json.loads((run / "cpu_s.json").read_text())["cpu_s"]
    if "M_heldout" in keys:
        cache = run / f"heldout_m{HELDOUT_COUNT}_at{at or len(data)}.json"
        if not cache.exists():
            cache.write_text(json.dumps({"seeds": HELDOUT_COUNT, "design": int(best),
                                         "M_heldout": heldout_m(run, data.X[best])}))
        out["M_heldout"] = json.loads(cache.read_text())["M_heldout"]
    else:
        problem = build_problem(OmegaConf.load(run / ".hydra" / "config.yaml"))
        out.update(indicator_values(problem, data.F[pareto], reference_front(problem)))
    return out


def score(study: str, out: Path, at: int | None) -> dict[str, dict[str, dict[int, float]]]:
    """{variant: {metric: {seed: value}}} over the variant's complete runs."""
    _, variants, keys, _ = STUDIES[study]
    table: dict[str, dict[str, dict[int, float]]] = {}
    for variant in variants:
        rows: dict[str, dict[int, float]] = {k: {} for k in (*keys, "wall_time_s", "cpu_s")}
        for run in sorted((out / study / variant).glob("seed*")):
            if not _complete(run):
                continue
            metrics = json.loads((run / "metrics.json").read_text())
            values = run_values(run, metrics, keys, at)
            if values is not None:
                for k in rows:
                    rows[k][int(run.name[4:])] = values.get(k)
        table[variant] = rows
    return table


def report(study: str, table: dict, at: int | None) -> None:
    for other in (v for v in table if v != "new"):
        report_pair(study, {k: list(v.values()) for k, v in table["new"].items()},
                    {k: list(v.values()) for k, v in table[other].items()}, other, at)
        report_paired(study, table["new"], table[other], other)


def report_paired(study: str, new: dict, ref: dict, other: str) -> None:
    """Per seed (the seeds both variants finished): each metric of both, and the CPU
    ratio other / new; then medians and the two-sided Wilcoxon signed-rank test of the
    paired differences (the same seed = the same initial designs)."""
    from scipy.stats import wilcoxon

    keys = [k for k in new if k not in ("wall_time_s", "cpu_s")]
    seeds = sorted(set(new[keys[0]]) & set(ref[keys[0]]))
    if not seeds:
        return
    print(f"\n### {study}: new vs {other}, paired by seed ({len(seeds)} seeds)\n")
    print("| seed | " + " | ".join(f"{k} new | {k} {other}" for k in keys)
          + f" | CPU s new | CPU s {other} | {other} / new |")
    print("|---|" + "---|---|" * len(keys) + "---|---|---|")
    for s in seeds:
        cells = " | ".join(f"{_fmt(new[k].get(s))} | {_fmt(ref[k].get(s))}" for k in keys)
        a, b = new["cpu_s"].get(s), ref["cpu_s"].get(s)
        print(f"| {s} | {cells} | {_fmt(a)} | {_fmt(b)} | {_fmt(a and b and b / a)} |")
    for k in keys:
        pairs = [(new[k].get(s), ref[k].get(s)) for s in seeds]
        pairs = np.array([p for p in pairs if None not in p and np.all(np.isfinite(p))])
        if len(pairs) < 2:
            print(f"{k}: {len(pairs)} finite pairs")
            continue
        diff = pairs[:, 0] - pairs[:, 1]
        p = wilcoxon(diff).pvalue if np.any(diff != 0) else 1.0
        wins = int(np.sum(diff < 0 if LOWER_IS_BETTER.get(k, True) else diff > 0))
        print(f"{k}: median new {np.median(pairs[:, 0]):.4g}, {other} "
              f"{np.median(pairs[:, 1]):.4g}; median paired difference (new - {other}) "
              f"{np.median(diff):+.3g}; new better in {wins}/{len(pairs)}; "
              f"signed-rank p = {fmt_p(p)}")
    timed = [s for s in seeds if new["cpu_s"].get(s) and ref["cpu_s"].get(s)]
    if not timed:
        return
    ratio = np.array([ref["cpu_s"][s] / new["cpu_s"][s] for s in timed])
    print(f"CPU per run, {other} / new: median {np.median(ratio):.1f} "
          f"(range {ratio.min():.1f}-{ratio.max():.1f}); total "
          f"{sum(ref['cpu_s'][s] for s in timed) / sum(new['cpu_s'][s] for s in timed):.1f} "
          f"({len(timed)} seeds timed)")


def _fmt(x) -> str:
    return "" if x is None else f"{x:.4g}"


def report_pair(study: str, new: dict, ref: dict, other: str, at: int | None) -> None:
    when = f"after {at} evaluations" if at else "at the runs' ends"
    print(f"\n## {study}, {when}: new vs {other} (mean ± std over seeds; p: two-sided "
          f"rank-sum)\n")
    print(f"| metric | new | {other} | p | new better? |")
    print("|---|---|---|---|---|")
    for k in new:
        a, b = _finite(new[k]), _finite(ref[k])
        if not len(a) or not len(b):
            print(f"| {k} | n={len(a)} | n={len(b)} | | |")
            continue
        p = rank_sum(a, b) if len(a) > 1 and len(b) > 1 else float("nan")
        better = np.median(a) < np.median(b) if LOWER_IS_BETTER.get(k, True) \
            else np.median(a) > np.median(b)
        print(f"| {k} | {a.mean():.4g} ± {a.std(ddof=1) if len(a) > 1 else 0:.2g} (n={len(a)}) "
              f"| {b.mean():.4g} ± {b.std(ddof=1) if len(b) > 1 else 0:.2g} (n={len(b)}) "
              f"| {fmt_p(p)} | {'yes' if better else 'no'} (medians) |")


def _finite(values) -> np.ndarray:
    return np.array([v for v in values if v is not None and np.isfinite(v)], dtype=float)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("study", nargs="?", choices=sorted(STUDIES))
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--out", type=Path, default=REPO / "multirun" / "speed_quality")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--variants", nargs="+", default=None,
                    help="run only these variants of the study (the report shows all)")
    ap.add_argument("--seed-list", type=int, nargs="+", default=None,
                    help="run these seeds, in this order (default: 0 .. --seeds - 1); a "
                         "second process with the seeds in reverse order shares the work")
    ap.add_argument("--at", type=int, default=None,
                    help="compare after this many evaluations (default: the study's)")
    ap.add_argument("--budget", type=int, default=None,
                    help="run every variant to this budget only and compare there (a run's "
                         "first evaluations do not depend on its budget); use its own --out")
    args = ap.parse_args()
    if args.list or args.study is None:
        for name, (common, variants, keys, at) in STUDIES.items():
            print(f"{name}: {' '.join(common)}; variants {dict(variants)}; metrics {keys}; "
                  f"compared at {at or 'the end'}")
        return
    if args.seeds < 2:
        sys.exit("speed_quality: --seeds must be >= 2 (a rank-sum test needs two runs)")
    if args.budget is not None and not 2 <= args.budget <= 10_000:
        sys.exit(f"speed_quality: --budget must be in [2, 10000], got {args.budget}")
    if not args.report_only:
        run_sweep(args.study, args.seed_list or list(range(args.seeds)), args.out, args.budget,
                  args.variants)
    at = args.at or args.budget or STUDIES[args.study][3]
    report(args.study, score(args.study, args.out, at), at)


if __name__ == "__main__":
    main()
