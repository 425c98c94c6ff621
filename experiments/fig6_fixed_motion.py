"""Fig. 6: identification of k1xx for x1 = 5e-5 sin(2 pi t/300), x2 = 3e-5 sin(2 pi t/500).

Usage: python experiments/fig6_fixed_motion.py [--out DIR] [--seed 0] [--seeds 20]

Prints convergence time (Eq. 18, eps = 1e-10 s^-2), convergence accuracy (Eq. 19), final
accuracy, max tracking error and steady tracking error (t >= 120 s, "within 2 min") for
the noise realisation ``--seed``, then mean and spread over ``--seeds`` realisations
(the paper reports one run).  Paper: 309.6 s, 7.86e-10 s^-2, < 5e-6 m, < 3e-9 m.
"""

from __future__ import annotations

import argparse
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tmopt.physics.excitation import MultiSine  # noqa: E402
from tmopt.physics.objectives import evaluate  # noqa: E402
from tmopt.physics.report import output_dir, write_csv, write_rows  # noqa: E402
from tmopt.physics.simulator import SimulationConfig, simulate  # noqa: E402

REF1 = MultiSine(5e-5, 2 * math.pi / 300)
REF2 = MultiSine(3e-5, 2 * math.pi / 500)


def run(seed: int, controller: str = "frbf_pid") -> tuple[object, dict]:
    cfg = SimulationConfig(controller=controller, steady_after=120.0)
    res = simulate(REF1, REF2, cfg, seed=seed)
    ev = evaluate(res, idx=0)
    row = {
        "seed": seed,
        "controller": controller,
        "convergence_time_s": float(ev["convergence_time"][0]),
        "convergence_accuracy": float(ev["convergence_accuracy"][0]),
        "final_accuracy": float(ev["final_accuracy"][0]),
        "M": float(ev["M"][0]),
        "max_error_x1_m": float(res.max_tracking_error[0, 0]),
        "max_error_x2_m": float(res.max_tracking_error[0, 1]),
        "steady_error_x1_m": float(res.steady_tracking_error[0, 0]),
        "steady_error_x2_m": float(res.steady_tracking_error[0, 1]),
    }
    return res, row


def plot(res, path) -> None:
    d = res.design(0)
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for ax, k in zip(axes[:2], ("1", "2")):
        ax.plot(d["time"], d[f"ref_x{k}"], "k--", lw=1, label="reference")
        ax.plot(d["time"], d[f"x{k}_true"], "C0", lw=0.8, label=f"x{k} (controlled)")
        ax.set_ylabel(f"TM{k} x [m]")
        ax.legend(loc="upper right")
    axes[2].plot(d["time"], d["theta_hat"][:, 0], "C0", lw=0.8, label="k1xx estimate")
    axes[2].axhline(res.config.theta_true[0], color="k", ls="--", lw=1, label="truth")
    axes[2].set_ylim(0.5e-7, 1.5e-7)
    axes[2].set_ylabel("k1xx [s^-2]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right")
    fig.suptitle("Fig. 6 reproduction")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description="Fig. 6 reproduction")
    ap.add_argument("--out", default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args()
    out = output_dir("fig6_fixed_motion", args.out)
    res, row = run(args.seed)
    d = res.design(0)
    write_csv(out / "fig6_timeseries.csv", {
        "time": d["time"], "ref_x1": d["ref_x1"], "x1_true": d["x1_true"],
        "ref_x2": d["ref_x2"], "x2_true": d["x2_true"], "k1xx_hat": d["theta_hat"][:, 0],
        "k2xx_hat": d["theta_hat"][:, 1],
    })  # fmt: skip
    plot(res, out / "fig6_fixed_motion.png")
    print("seed", args.seed, ", ".join(f"{k}={v:.4g}" for k, v in row.items()
                                       if isinstance(v, float)))  # fmt: skip
    rows = [run(s, ctl)[1] for ctl in ("frbf_pid", "pid") for s in range(args.seeds)]
    write_rows(out / "fig6_seeds.csv", rows)
    for ctl in ("frbf_pid", "pid"):
        sub = [r for r in rows if r["controller"] == ctl]
        for key in ("convergence_time_s", "convergence_accuracy", "final_accuracy",
                    "max_error_x1_m", "steady_error_x1_m"):  # fmt: skip
            v = np.array([r[key] for r in sub])
            print(f"{ctl:8s} {key:22s} over {len(v)} seeds: median {np.median(v):.4g}, "
                  f"mean {v.mean():.4g}, min {v.min():.4g}, max {v.max():.4g}")  # fmt: skip
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
