"""Same configurations and seeds, same archives: a refactoring changed no number.

    # run the standard handful of configurations with a checkout's code (its own tmopt/conf/)
    python experiments/check_same_archives.py run CHECKOUT OUT_DIR [--only NAME ...]
    # compare two sets of run folders (or two single run folders) bit for bit
    python experiments/check_same_archives.py compare DIR_A DIR_B
    # the configuration hash of every option, composed by each of two checkouts
    python experiments/check_same_archives.py hashes CHECKOUT_A CHECKOUT_B

``run`` starts ``python -m tmopt`` in ``CHECKOUT`` with that checkout first on the
import path, once per configuration of :data:`RUNS` (small budgets; mw3 and the stiffness
problem; the MGSAEA family, NSGA-II/III, C-TSEA, CMOES, C-MOEA/D, SSDE and qLogNEHVI),
each into ``OUT_DIR/<name>``. ``compare`` pairs the run folders under both directories by
their relative path and checks, for every pair, that ``archive.h5`` holds the same X, F,
G, failed, reason, seed and batch arrays (``np.array_equal`` on the raw float64 values:
bit for bit, NaN in the same places) and the same ``config_hash`` attribute (so an
interrupted run of the old code resumes under the new), and that ``metrics.json`` agrees
in every entry except the wall time. It prints one line per run and exits 1 on any
difference. ``hashes`` composes every problem, algorithm and surrogate option and every
preset (with the default configuration around it) in each checkout and compares their
``config_hash``: equal hashes mean that the runs of one resume or are skipped in the other.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

#: name -> overrides of ``python -m tmopt``; small budgets so that the set runs in minutes.
RUNS: dict[str, list[str]] = {
    "mw3_mgsaea_ipc_rbf": ["problem=mw3", "algorithm=mgsaea_ipc", "surrogate=rbf",
                           "budget=184"],
    "mw3_mgsaea_gp": ["problem=mw3", "algorithm=mgsaea", "surrogate=gp", "budget=174"],
    "mw3_mgsaea_star_rbf": ["problem=mw3", "algorithm=mgsaea_star", "surrogate=rbf",
                            "budget=184", "seed=1"],
    "mw3_nsga2": ["problem=mw3", "algorithm=nsga2", "budget=300"],
    "mw3_nsga3": ["problem=mw3", "algorithm=nsga3", "budget=300"],
    "mw3_ctsea": ["problem=mw3", "algorithm=ctsea", "budget=400"],
    "mw3_cmoes": ["problem=mw3", "algorithm=cmoes", "budget=400"],
    "mw3_cmoes_de": ["problem=mw3", "algorithm=cmoes", "algorithm.operator=de", "budget=400"],
    "mw3_cmoead": ["problem=mw3", "algorithm=cmoead", "budget=300"],
    "mw3_ssde": ["problem=mw3", "algorithm=ssde", "budget=250"],
    "mw3_qlognehvi": ["problem=mw3", "algorithm=qlognehvi", "budget=42",
                      "algorithm.raw_samples=32", "algorithm.acq_maxiter=20"],
    "stiffness_mgsaea_ipc_gp": ["problem=stiffness", "problem.n_freq=1", "algorithm=mgsaea_ipc",
                                "surrogate=gp", "budget=75"],
    "stiffness_nsga2": ["problem=stiffness", "problem.n_freq=1", "algorithm=nsga2",
                        "algorithm.pop_size=20", "budget=60", "seed=3"],
    "stiffness_ctsea_schemeA": ["problem=stiffness", "problem.n_freq=1", "scheme=A",
                                "algorithm=ctsea", "algorithm.pop_size=20", "budget=60"],
}
ARRAYS = ("X", "F", "G", "failed", "reason", "seed", "batch")
#: Run in a checkout: prints {overrides: config_hash} as JSON for every option. It works
#: with both layouts (tmopt.run.cli / tmopt.cli before the run package existed).
HASH_SCRIPT = """
import json, sys
from pathlib import Path
try:
    from tmopt.run import cli
    from tmopt.run.config import config_hash
except ImportError:
    from tmopt import cli
    from tmopt.config import config_hash
from hydra import compose
out = {}
combos = [[f"problem={p}"] for p in cli.available("problem")]
combos += [[f"algorithm={a}", f"problem={p}"] for a in cli.available("algorithm")
           for p in ("mw3", "stiffness")]
combos += [[f"surrogate={s}", "problem=mw3"] for s in cli.available("surrogate")]
combos += [[f"experiment={e}"] for e in cli.available("experiment")]
combos += [[f"scheme={s}"] for s in cli.available("scheme")]
with cli._hydra_context():
    for combo in combos:
        out[" ".join(combo)] = config_hash(compose(config_name="config", overrides=combo))
print(json.dumps(out))
"""


def run_all(checkout: Path, out: Path, only: list[str] | None) -> int:
    env = dict(os.environ, PYTHONPATH=str(checkout))
    failures = 0
    for name, overrides in RUNS.items():
        if only and name not in only:
            continue
        cmd = [sys.executable, "-m", "tmopt", *overrides, "progress=false", "plots=false",
               f"hydra.run.dir={(out / name).resolve()}"]
        t0 = time.perf_counter()
        done = subprocess.run(cmd, cwd=checkout, env=env, capture_output=True, text=True)
        status = "ok" if done.returncode == 0 else f"exit {done.returncode}"
        print(f"{name:28s} {status:8s} {time.perf_counter() - t0:7.1f} s", flush=True)
        if done.returncode:
            failures += 1
            print(done.stderr[-2000:], file=sys.stderr)
    return 1 if failures else 0


def _read(path: Path) -> tuple[dict, dict]:
    with h5py.File(path, "r") as h5:
        arrays = {k: h5[k][()] for k in ARRAYS}
        attrs = {k: v for k, v in h5.attrs.items()}
    return arrays, attrs


def compare_run(a: Path, b: Path) -> list[str]:
    """What differs between run folders ``a`` and ``b`` (empty: nothing)."""
    diffs = []
    xa, attrs_a = _read(a / "archive.h5")
    xb, attrs_b = _read(b / "archive.h5")
    for key in ARRAYS:
        same = xa[key].shape == xb[key].shape and xa[key].dtype == xb[key].dtype and (
            np.array_equal(xa[key], xb[key], equal_nan=True) if xa[key].dtype.kind == "f"
            else np.array_equal(xa[key], xb[key]))
        if not same:
            diffs.append(f"archive {key} differs ({xa[key].shape} vs {xb[key].shape})")
    for key in sorted(set(attrs_a) | set(attrs_b)):
        if attrs_a.get(key) != attrs_b.get(key):
            diffs.append(f"archive attribute {key}: {attrs_a.get(key)!r} vs {attrs_b.get(key)!r}")
    ma = json.loads((a / "metrics.json").read_text())
    mb = json.loads((b / "metrics.json").read_text())
    for key in sorted(set(ma) | set(mb)):
        if key != "wall_time_s" and ma.get(key) != mb.get(key):
            diffs.append(f"metrics.json {key} differs")
    return diffs


def compare_all(dir_a: Path, dir_b: Path) -> int:
    if (dir_a / "archive.h5").exists():
        pairs = [(dir_a, dir_b)]
    else:
        found = sorted(p.parent.relative_to(dir_a) for p in dir_a.rglob("archive.h5"))
        pairs = [(dir_a / rel, dir_b / rel) for rel in found]
    if not pairs:
        print(f"no run folder (archive.h5) under {dir_a}", file=sys.stderr)
        return 1
    bad = 0
    for a, b in pairs:
        if not (b / "archive.h5").exists():
            print(f"{a.name:28s} MISSING in {dir_b}")
            bad += 1
            continue
        diffs = compare_run(a, b)
        n = len(_read(a / "archive.h5")[0]["X"])
        print(f"{a.name:28s} {n:4d} evaluations  " + ("identical" if not diffs else
                                                     "DIFFERENT: " + "; ".join(diffs)))
        bad += bool(diffs)
    print(f"{len(pairs) - bad} of {len(pairs)} runs identical")
    return 1 if bad else 0


def config_hashes(checkout: Path) -> dict[str, str]:
    """``{overrides: config_hash}`` of every option as ``checkout``'s code composes it."""
    env = dict(os.environ, PYTHONPATH=str(checkout.resolve()))
    done = subprocess.run([sys.executable, "-c", HASH_SCRIPT], cwd=checkout, env=env,
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def compare_hashes(checkout_a: Path, checkout_b: Path) -> int:
    a, b = config_hashes(checkout_a), config_hashes(checkout_b)
    differ = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    for key in differ:
        print(f"{key:40s} {a.get(key, 'missing')} vs {b.get(key, 'missing')}")
    print(f"{len(set(a) | set(b)) - len(differ)} of {len(set(a) | set(b))} configurations "
          "have the same config_hash")
    return 1 if differ else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run the standard configurations with a checkout")
    run.add_argument("checkout", type=Path)
    run.add_argument("out", type=Path)
    run.add_argument("--only", nargs="*", choices=sorted(RUNS))
    cmp_ = sub.add_parser("compare", help="compare two run folders or two sets of them")
    cmp_.add_argument("dir_a", type=Path)
    cmp_.add_argument("dir_b", type=Path)
    hashes = sub.add_parser("hashes", help="compare the config_hash of every option")
    hashes.add_argument("checkout_a", type=Path)
    hashes.add_argument("checkout_b", type=Path)
    args = parser.parse_args(argv)
    if args.command == "run":
        if not (args.checkout / "tmopt").is_dir():
            parser.error(f"checkout={args.checkout} is invalid: it must hold the tmopt package")
        return run_all(args.checkout.resolve(), args.out, args.only)
    if args.command == "hashes":
        return compare_hashes(args.checkout_a, args.checkout_b)
    return compare_all(args.dir_a, args.dir_b)


if __name__ == "__main__":
    sys.exit(main())
