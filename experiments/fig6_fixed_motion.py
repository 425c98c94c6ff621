"""Fig. 6: identification of k1xx for x1 = 5e-5 sin(2 pi t/300), x2 = 3e-5 sin(2 pi t/500).

Usage: python experiments/fig6_fixed_motion.py [--out DIR] [--seeds 10]

Prints, median (min-max) over ``--seeds`` noise seeds, for the default setting and the
variants the issue-17 decisions are measured against (no ramp-in; the round-one y axes
with all five RLS columns; the round-one y axes with the default columns; and all three
round-one settings together, i.e. the simulator before issue 17 -- bit for bit with the
PID) and both controllers: convergence time
(Eq. 18, eps = 1e-10 s^-2), convergence accuracy (Eq. 19), final accuracy, the largest
tracking error, the steady tracking error (t >= 120 s, "within 2 min"), the realised
max |x1| and max |u1| and Eq. 20 on them.  Paper: 309.6 s, 7.86e-10 s^-2, < 5e-6 m,
< 3e-9 m.  Writes the per-seed CSV, the seed-0 time series and the figure.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tmopt.physics.excitation import MultiSine  # noqa: E402
from tmopt.physics.objectives import eq20_realised, evaluate  # noqa: E402
from tmopt.physics.report import (  # noqa: E402
    FIG6_REFERENCES,
    fmt_stats,
    output_dir,
    write_csv,
    write_rows,
)
from tmopt.physics.scenario import config_at_rate  # noqa: E402
from tmopt.physics.simulator import SimulationConfig, simulate  # noqa: E402

REF1, REF2 = (MultiSine(a, w) for a, w in FIG6_REFERENCES)
BASE = SimulationConfig(steady_after=120.0)
VARIANTS = {
    "default": BASE,
    "no ramp-in": replace(BASE, ramp_in=0.0),
    "round-one y, all columns": config_at_rate(y_axes="round1", steady_after=120.0,
                                               rls_columns="all"),
    "round-one y, default columns": config_at_rate(y_axes="round1", steady_after=120.0),
    "round one (no ramp, round-one y, all columns)": config_at_rate(
        y_axes="round1", steady_after=120.0, ramp_in=0.0, rls_columns="all"),
}
KEYS = (("convergence_time_s", ".4g"), ("convergence_accuracy", ".3g"),
        ("final_accuracy", ".3g"), ("max_error_x1_m", ".3g"), ("steady_error_x1_m", ".3g"),
        ("max_abs_x1_m", ".4g"), ("max_abs_u1", ".3g"), ("eq20_force_TM1", ".3f"),
        ("eq20_motion_TM1", ".3f"))  # fmt: skip


def run(cfg: SimulationConfig, seed: int) -> tuple[object, dict]:
    res = simulate(REF1, REF2, cfg, seed=seed)
    ev = evaluate(res, idx=0)
    g = eq20_realised(res)[0]
    row = {
        "convergence_time_s": float(ev["convergence_time"][0]),
        "convergence_accuracy": float(ev["convergence_accuracy"][0]),
        "final_accuracy": float(ev["final_accuracy"][0]),
        "max_error_x1_m": float(res.max_tracking_error[0, 0]),
        "steady_error_x1_m": float(res.steady_tracking_error[0, 0]),
        "max_abs_x1_m": float(res.max_abs_position[0, 0]),
        "max_abs_u1": float(res.max_abs_command[0, 0]),
        "eq20_force_TM1": float(g[0] / (cfg.alpha1 * cfg.f_max)),
        "eq20_motion_TM1": float(g[1] / (cfg.alpha2 * cfg.gap)),
    }
    return res, row


def plot(runs: dict, path) -> None:
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    d = runs["default"].design(0)
    for ax, k in zip(axes[:2], ("1", "2")):
        ax.plot(d["time"], d[f"ref_x{k}"], "k--", lw=1, label="reference (ramped in)")
        ax.plot(d["time"], d[f"x{k}_true"], "C0", lw=0.8, label=f"x{k} (controlled)")
        ax.set_ylabel(f"TM{k} x [m]")
        ax.legend(loc="upper right", fontsize=8)
    for (label, res), color in zip(runs.items(), ("C0", "C1", "C2", "C3", "C4")):
        axes[2].plot(res.time, res.theta_hat[0, :, 0], color=color, lw=0.8, label=label)
    axes[2].axhline(BASE.theta_true[0], color="k", ls="--", lw=1, label="truth")
    axes[2].set_ylim(0.5e-7, 1.5e-7)
    axes[2].set_ylabel("k1xx estimate [s^-2]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right", fontsize=7)
    fig.suptitle("Fig. 6 reproduction (FRBF-PID, seed 0)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description="Fig. 6 reproduction")
    ap.add_argument("--out", default=None)
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args()
    out = output_dir("fig6_fixed_motion", args.out)
    rows, seed0 = [], {}
    for label, cfg in VARIANTS.items():
        for controller in ("frbf_pid", "pid"):
            for seed in range(args.seeds):
                res, row = run(replace(cfg, controller=controller), seed)
                rows.append({"variant": label, "controller": controller, "seed": seed, **row})
                if seed == 0 and controller == "frbf_pid":
                    seed0[label] = res
    write_rows(out / "fig6_seeds.csv", rows)
    d = seed0["default"].design(0)
    write_csv(out / "fig6_timeseries_seed0.csv", {
        "time": d["time"], "ref_x1": d["ref_x1"], "x1_true": d["x1_true"],
        "ref_x2": d["ref_x2"], "x2_true": d["x2_true"], "k1xx_hat": d["theta_hat"][:, 0],
        "k2xx_hat": d["theta_hat"][:, 1],
    })  # fmt: skip
    plot(seed0, out / "fig6_fixed_motion.png")
    print(f"Fig. 6, median (min-max) over {args.seeds} noise seeds; paper: 309.6 s, "
          f"7.86e-10 s^-2, max error < 5e-6 m, steady error < 3e-9 m")  # fmt: skip
    for label in VARIANTS:
        for controller in ("frbf_pid", "pid"):
            sub = [r for r in rows if r["variant"] == label and r["controller"] == controller]
            print(f"[{label}, {controller}]")
            for key, fmt in KEYS:
                print(f"  {key:22s} {fmt_stats([r[key] for r in sub], fmt)}")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
