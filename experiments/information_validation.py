"""Information-matrix predictions of Eqs. 18-19 against Monte Carlo over noise seeds.

Usage: python experiments/information_validation.py [--designs 12] [--seeds 200] [--out DIR]

``problem.noise=information`` scores a design by the expected convergence time, accuracy
and M that its noise-free realised regressors and the known noise level imply
(tmopt.physics.information).  This script checks those expectations against the
simulator itself: the Fig. 6 state, ``--designs`` three-frequency pairs that satisfy Eq. 20
a priori (tmopt.physics.report.study_designs) and the near-optimal motion of the floor
(tmopt.physics.floor.near_optimal_motion, TM2 at rest), each run on ``--seeds`` noise
seeds (held-out seeds, one simulator call per design).  It prints, per design, the
prediction, the Monte Carlo mean with its standard error, and their ratio; then the
median and worst ratios and the rank correlation of predicted and simulated M over the
designs (what an optimiser needs).  The floor (tmopt.physics.floor) is printed beside the
final accuracy.  Writes a CSV.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from scipy.stats import spearmanr

from tmopt.physics import objectives as po
from tmopt.physics.floor import near_optimal_motion, stiffness_floor
from tmopt.physics.information import equation_noise_sigma, noise_free, predict
from tmopt.physics.noise import heldout_seeds
from tmopt.physics.report import output_dir, study_designs, write_rows
from tmopt.physics.simulator import simulate
from tmopt.problems.stiffness import StiffnessProblem

QUANTITIES = ("convergence_time", "convergence_accuracy", "final_accuracy", "M")


def references(n: int, cfg) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(name, ref1 (N,), ref2 (N,)) of every design, sampled on the run's grid."""
    t = np.arange(cfg.n_steps) / cfg.sample_rate
    r1, r2 = study_designs(n)
    out = [("fig6" if i == 0 else f"feasible-{i}", r1.take(i).evaluate(t)[0],
            r2.take(i).evaluate(t)[0]) for i in range(r1.batch_size)]  # fmt: skip
    x = near_optimal_motion(stiffness_floor(cfg, 0, "realised"))
    out.append(("near-optimal", x, np.zeros_like(x)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=12)
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    out = output_dir("information_validation", args.out)
    cfg = StiffnessProblem().config  # the problem's physics (ramp-in, RLS columns, ...)
    sigma_e = equation_noise_sigma(cfg)
    seeds = heldout_seeds(args.seeds)
    floor = stiffness_floor(cfg, 0, "realised")
    rows = []
    t0 = time.perf_counter()
    for name, r1, r2 in references(args.designs, cfg):
        free = simulate(r1[None], r2[None], replace(noise_free(cfg), record="full"))
        pred = {k: float(v[0]) for k, v in predict(free, sigma_e).items()}
        res = simulate(np.tile(r1, (len(seeds), 1)), np.tile(r2, (len(seeds), 1)), cfg,
                       seed=seeds)  # fmt: skip
        mc = po.evaluate(res, idx=0)
        row = {"design": name}
        for q in QUANTITIES:
            v = np.asarray(mc[q], float)
            row[f"{q}_pred"] = pred[q]
            row[f"{q}_mc"] = float(v.mean())
            row[f"{q}_se"] = float(v.std(ddof=1) / np.sqrt(v.size))
            row[f"{q}_ratio"] = pred[q] / float(v.mean())
        err = res.theta_hat[:, -1, 0] - cfg.theta_true[0]
        row["final_sd_pred"] = pred["final_sd"]
        row["final_rms_mc"] = float(np.sqrt(np.mean(err**2)))
        row["floor_final_rms"] = floor.final
        row["diverged"] = int(res.diverged.sum())
        rows.append(row)
        print(f"{name:14s} " + "  ".join(
            f"{q[:12]} {row[f'{q}_pred']:.4g}/{row[f'{q}_mc']:.4g}±{row[f'{q}_se']:.2g}"
            for q in QUANTITIES) + f"  final sd {pred['final_sd']:.3g}/{row['final_rms_mc']:.3g}",
            flush=True)  # fmt: skip
    write_rows(out / "information_validation.csv", rows)
    print(f"\n{len(rows)} designs x {len(seeds)} seeds in {time.perf_counter() - t0:.0f} s; "
          f"floor of the final accuracy (rms) {floor.final:.3g} s^-2")
    for q in (*QUANTITIES, "final_sd"):
        if q == "final_sd":
            ratio = np.array([r["final_sd_pred"] / r["final_rms_mc"] for r in rows])
        else:
            ratio = np.array([r[f"{q}_ratio"] for r in rows])
        print(f"{q:22s} predicted / simulated: median {np.median(ratio):.3f}, "
              f"range {ratio.min():.3f}-{ratio.max():.3f}")
    rho = spearmanr([r["M_pred"] for r in rows], [r["M_mc"] for r in rows]).statistic
    print(f"rank correlation of predicted and simulated mean M over designs: {rho:.3f}")
    print(f"written: {out / 'information_validation.csv'}")


if __name__ == "__main__":
    main()
