"""Start-up transient vs a ramp-in of the reference: Eq. 20 on the realised motion.

Usage: python experiments/start_ramp_study.py [--designs 100] [--seeds 10] [--out DIR]
       [--ramps 0 30 60 90 120 180]

Every reference of Eq. 17 starts at x = 0 with velocity ``sum_i A_i w_i cos(theta_i)``
while the test mass is at rest, so the loop must catch up; at F_max = 1e-7 m s^-2 that
takes tens of seconds for the faster designs and the TM overshoots the reference.  This
study simulates ``--designs`` pairs of three-frequency references (TM1 and TM2) that
satisfy Eq. 20 *a priori* (``feasible_population``) plus the paper's Fig. 6 state, for each
ramp-in length ``SimulationConfig.ramp_in`` and both controllers, over ``--seeds`` noise
seeds, and prints per ramp: the share of designs whose *realised* motion (``max|x| >
alpha2 D``) or commanded force (``max|u| > alpha1 F_max``) violates Eq. 20, the median
maximum tracking error, and the convergence time and accuracy of k1xx (median over
designs of the per-design median over seeds).  Writes a CSV and a PNG.
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tmopt.physics.excitation import MultiSine  # noqa: E402
from tmopt.physics.objectives import eq20_realised, evaluate  # noqa: E402
from tmopt.physics.report import output_dir, study_designs, write_rows  # noqa: E402
from tmopt.physics.simulator import SimulationConfig, simulate  # noqa: E402


def run(ramp: float, controller: str, seeds: int, r1: MultiSine, r2: MultiSine) -> dict:
    cfg = SimulationConfig(controller=controller, ramp_in=ramp, record="estimates")
    lim = np.array([cfg.alpha1 * cfg.f_max, cfg.alpha2 * cfg.gap] * 2)
    g, err, t1, a1 = [], [], [], []
    for seed in range(seeds):
        res = simulate(r1, r2, cfg, seed=seed)
        g.append(eq20_realised(res) / lim)  # value / limit - 1
        err.append(res.max_tracking_error[:, 0])
        ev = evaluate(res, idx=0)
        t1.append(ev["convergence_time"])
        a1.append(ev["convergence_accuracy"])
    return {k: np.array(v) for k, v in (("g", g), ("err", err), ("t1", t1), ("a1", a1))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=100)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--ramps", type=float, nargs="+", default=[0, 30, 60, 90, 120, 180])
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    out = output_dir("start_ramp_study", args.out)
    r1, r2 = study_designs(args.designs)
    rows = []
    curves: dict[str, dict[str, list[float]]] = {}
    for controller in ("pid", "frbf_pid"):
        base = None
        for ramp in args.ramps:
            d = run(ramp, controller, args.seeds, r1, r2)
            pop = slice(1, None)  # the population; index 0 is the Fig. 6 state
            # a design violates when it does so for the median seed
            med_g = np.median(d["g"], axis=0)  # (designs, 4)
            t1 = np.median(d["t1"], axis=0)
            if base is None:
                base = t1
            row = {
                "controller": controller, "ramp_s": ramp,
                "motion_violated_TM1": float(np.mean(med_g[pop, 1] > 0)),
                "motion_violated_TM2": float(np.mean(med_g[pop, 3] > 0)),
                "force_violated_TM1": float(np.mean(med_g[pop, 0] > 0)),
                "force_violated_TM2": float(np.mean(med_g[pop, 2] > 0)),
                "median_max_tracking_error_TM1_m": float(np.median(d["err"][:, pop])),
                "median_convergence_time_s": float(np.median(t1[pop])),
                "median_change_vs_ramp0_s": float(np.median(t1[pop] - base[pop])),
                "median_convergence_accuracy": float(np.median(d["a1"][:, pop])),
                "fig6_max_x1_over_limit": float(np.median(d["g"][:, 0, 1])) + 1,
                "fig6_max_u1_over_limit": float(np.median(d["g"][:, 0, 0])) + 1,
                "fig6_max_tracking_error_m": float(np.median(d["err"][:, 0])),
                "fig6_convergence_time_s": float(np.median(d["t1"][:, 0])),
            }  # fmt: skip
            rows.append(row)
            for key in ("motion_violated_TM1", "force_violated_TM1",
                        "median_max_tracking_error_TM1_m", "median_convergence_time_s"):
                curves.setdefault(f"{controller}:{key}", {}).setdefault("y", []).append(row[key])
            print(", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                            for k, v in row.items()), flush=True)  # fmt: skip
    write_rows(out / "start_ramp_study.csv", rows)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    keys = [("motion_violated_TM1", "share violating max|x1| < alpha2 D"),
            ("force_violated_TM1", "share violating max|u1| < alpha1 F_max"),
            ("median_max_tracking_error_TM1_m", "median max tracking error TM1 [m]"),
            ("median_convergence_time_s", "median convergence time k1xx [s]")]  # fmt: skip
    for ax, (key, label) in zip(axes.ravel(), keys):
        for controller, style in (("pid", "C1o--"), ("frbf_pid", "C0s-")):
            ax.plot(args.ramps, curves[f"{controller}:{key}"]["y"], style, label=controller)
        ax.set_ylabel(label, fontsize=8)
        if "error" in key:
            ax.set_yscale("log")
        ax.legend(fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("ramp-in length [s]")
    fig.suptitle(f"{args.designs} a-priori feasible 3-frequency designs, "
                 f"{args.seeds} noise seeds")  # fmt: skip
    fig.tight_layout()
    fig.savefig(out / "start_ramp_study.png", dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
