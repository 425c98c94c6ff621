"""Which solver for the next-excitation design: cost and quality of each, side by side.

Usage: python experiments/design_solvers.py [--effect stiffness_cross_coupling]
       [--seeds 3] [--solvers nsga2:96,nsga2:1200,mgsaea:400] [--out DIR]

One recording with the effect concealed under the paper's excitation (the loop's first
step, ``experiments/design_next_loop.py``, seed 1) is diagnosed once; its design problem
(every flagged target, the loop's design space) is then solved by each solver
``NAME:BUDGET`` (a name of the algorithm registry, real evaluations; ``nsga2`` runs a
population of 16 below 400 evaluations, 40 above) on ``--seeds`` optimiser seeds. For
each run: the CPU seconds of this process (``time.process_time``: the machine is
shared, so wall time says little), evaluations, and what the choice rule took --
feasible, every target detectable, k1xx's predicted standard error, the worst
``z sigma / plausible`` over the targets (below 1: detectable) and the duration.
Writes ``solvers.json`` and ``solvers.md`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from tmopt.design.plan import plan_from_diagnosis
from tmopt.design.problem import DesignSpace
from tmopt.mismatch.diagnose import diagnose
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generate import generate_recording

sys.path.insert(0, str(Path(__file__).resolve().parent))
from design_next_loop import CASES  # noqa: E402  (the loop's effects: one home)


def one(dg, name: str, budget: int, seed: int) -> dict:
    t0 = time.process_time()
    pop = 16 if budget < 400 else 40
    p = plan_from_diagnosis(dg, DesignSpace(duration=(600.0, 1200.0)), algorithm=name,
                            budget=budget, pop_size=pop, seed=seed)  # fmt: skip
    cpu = time.process_time() - t0
    worst = max(p.after.se[t.key] * p.z / t.plausible for t in p.problem.targets)
    return {"solver": name, "budget": budget, "seed": seed, "cpu_s": cpu,
            "n_evaluated": p.n_evaluated, "feasible": bool(p.feasible),
            "all_detectable": bool(p.all_detectable), "se_k1xx": p.after.se["k1xx"],
            "worst_z_sigma_over_plausible": worst, "duration_s": p.duration,
            "excitation": p.spec}  # fmt: skip


def table(rows: list[dict]) -> str:
    lines = ["| solver | budget | seeds | CPU s per design run (median) | feasible | all "
             "detectable | k1xx SE (median) | worst z sigma / plausible (median) | "
             "duration s (median) |", "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    keys = sorted({(r["solver"], r["budget"]) for r in rows}, key=lambda k: (k[0], k[1]))
    for name, budget in keys:
        rs = [r for r in rows if r["solver"] == name and r["budget"] == budget]
        med = {k: float(np.median([r[k] for r in rs]))
               for k in ("cpu_s", "se_k1xx", "worst_z_sigma_over_plausible", "duration_s")}
        lines.append(f"| {name} | {budget} | {len(rs)} | {med['cpu_s']:.0f} | "
                     f"{sum(r['feasible'] for r in rs)}/{len(rs)} | "
                     f"{sum(r['all_detectable'] for r in rs)}/{len(rs)} | "
                     f"{med['se_k1xx']:.3g} | {med['worst_z_sigma_over_plausible']:.3g} | "
                     f"{med['duration_s']:.0f} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--effect", default="stiffness_cross_coupling")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--solvers", default="nsga2:96,nsga2:1200,mgsaea:400")
    ap.add_argument("--out", default="outputs/design_solvers")
    args = ap.parse_args(argv)
    if args.effect not in CASES or args.seeds < 1:
        ap.error(f"--effect must be one of {list(CASES)} and --seeds >= 1")
    solvers = [(s.split(":")[0], int(s.split(":")[1])) for s in args.solvers.split(",")]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rec, _ = generate_recording([CASES[args.effect][0]], seed=1)
    dg = diagnose(data_from_recording(rec))
    rows = []
    for name, budget in solvers:
        for seed in range(args.seeds):
            row = one(dg, name, budget, seed)
            rows.append(row)
            print(f"{name}:{budget} seed {seed}: {row['cpu_s']:.0f} CPU s, "
                  f"feasible={row['feasible']} detectable={row['all_detectable']} "
                  f"k1xx SE {row['se_k1xx']:.3g} worst {row['worst_z_sigma_over_plausible']:.3g} "
                  f"{row['duration_s']:.0f} s", flush=True)  # fmt: skip
            (out / "solvers.json").write_text(json.dumps(rows, indent=1))
    text = table(rows)
    (out / "solvers.md").write_text(text)
    print(text)
    return 0 if all(math.isfinite(r["se_k1xx"]) for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
