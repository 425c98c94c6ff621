"""Share of a sweep's evaluated designs that keep Eq. 20 realised vs a priori (issue 18).

    python experiments/realised_feasible_share.py multirun/pilot_noise

For every run folder of the sweep (stiffness problem, scheme B or C): the recorded realised
constraints of each evaluated design (archive.csv, the simulated motion and force) against
``StiffnessProblem.reference_constraints`` of the same design (round one's a-priori form).
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import yaml

from tmopt.problems.stiffness import StiffnessProblem

G_COLUMNS = ("actuation_TM1", "displacement_TM1", "actuation_TM2", "displacement_TM2")


def shares(run: Path) -> tuple[int, float, float, float, float]:
    """(evaluations, realised share, a-priori share, a priori only, realised only)."""
    cfg = yaml.safe_load((run / "config.yaml").read_text())["problem"]
    problem = StiffnessProblem(scheme=cfg["scheme"], n_freq=cfg["n_freq"])
    rows = [r for r in csv.DictReader(open(run / "archive.csv")) if r["failed"] == "0"]
    X = np.array([[float(r[f"x{i + 1}"]) for i in range(problem.n_var)] for r in rows])
    G = np.array([[float(r[c]) for c in G_COLUMNS if c in r] for r in rows])
    realised = np.all(G <= 0, axis=1)
    prior = np.concatenate([np.all(problem.reference_constraints(chunk) <= 0, axis=1)
                            for chunk in np.array_split(X, max(1, len(X) // 50))])
    return (len(rows), realised.mean(), prior.mean(), np.mean(prior & ~realised),
            np.mean(realised & ~prior))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep_dir", type=Path)
    runs = sorted(p.parent for p in parser.parse_args().sweep_dir.glob("*/archive.csv"))
    table = []
    for run in runs:
        table.append(shares(run))
        n, real, prior, prior_only, real_only = table[-1]
        print(f"{run.name:70s} n={n} realised {real:.3f} a priori {prior:.3f} "
              f"a priori only {prior_only:.3f} realised only {real_only:.3f}", flush=True)
    if table:
        real, prior, prior_only, real_only = np.mean([t[1:] for t in table], axis=0)
        print(f"mean over {len(table)} runs: realised {real:.3f} a priori {prior:.3f} "
              f"a priori only {prior_only:.3f} realised only {real_only:.3f}")


if __name__ == "__main__":
    main()
