"""Which columns of Eq. 14 the RLS identifies, and how the y-axes setting interacts.

Usage: python experiments/rls_columns_study.py [--designs 100] [--seeds 10] [--out DIR]

theta = [k1xx, k2xx, k1yy, k2yy, R] (Eqs. 10-15).  The non-sensitive axes are held at
nominal, so their regressors K3 y1, K4 y2 are readout noise (N_m2 = 1e-8 m) plus a small
loop residual, and k1yy, k2yy are not identifiable from them; identifying them anyway
adds two columns whose estimates wander and leak into k1xx.  Column sets compared
(``SimulationConfig.rls_columns``): ``all`` (the five), ``sensitive`` (k1xx, k2xx, R) and
``k1xx+R`` (TM2's stiffness term left in the equation error: biased whenever TM2 moves).
For the Fig. 6 state and ``--designs`` a-priori feasible three-frequency pairs, with both
y-axes settings (``Y_AXES``: drag_free, round1), over ``--seeds`` noise seeds: convergence
time / accuracy / final error of k1xx (median over seeds, and over designs), the bias
of the final estimate (|mean over seeds| / (spread / sqrt(seeds))), and each set's paired
change against ``all``.
"""

from __future__ import annotations

import argparse

import numpy as np

from tmopt.physics.objectives import evaluate
from tmopt.physics.report import fmt_stats, output_dir, study_designs, write_rows
from tmopt.physics.scenario import config_at_rate
from tmopt.physics.simulator import SimulationConfig, simulate

SETS = {"all": "all", "sensitive": "sensitive", "k1xx+R": ("k1xx", "R")}


def run(cfg: SimulationConfig, seeds: int, r1, r2) -> dict[str, np.ndarray]:
    """(seeds, designs) arrays of the k1xx objectives and the final signed error."""
    out = {k: [] for k in ("t", "a", "f", "signed")}
    for seed in range(seeds):
        res = simulate(r1, r2, cfg, seed=seed)
        ev = evaluate(res, idx=0)
        out["t"].append(ev["convergence_time"])
        out["a"].append(ev["convergence_accuracy"])
        out["f"].append(ev["final_accuracy"])
        out["signed"].append(res.theta_hat[:, -1, 0] - cfg.theta_true[0])
    return {k: np.array(v) for k, v in out.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=100)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--ramp", type=float, default=SimulationConfig.ramp_in)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    out = output_dir("rls_columns_study", args.out)
    r1, r2 = study_designs(args.designs)
    rows = []
    for y_axes in ("drag_free", "round1"):
        ref = None
        for name, cols in SETS.items():
            cfg = config_at_rate(y_axes=y_axes, record="estimates", ramp_in=args.ramp,
                                 rls_columns=cols)  # fmt: skip
            d = run(cfg, args.seeds, r1, r2)
            if ref is None:
                ref = d
            t_med = np.median(d["t"], axis=0)
            bias = np.abs(d["signed"].mean(axis=0)) / (
                d["signed"].std(axis=0, ddof=1) / np.sqrt(args.seeds) + 1e-30)
            pop = slice(1, None)
            row = {
                "y_axes": y_axes, "columns": name,
                "fig6_convergence_time_s": fmt_stats(d["t"][:, 0], ".4g"),
                "fig6_convergence_accuracy": fmt_stats(d["a"][:, 0]),
                "fig6_final_error": fmt_stats(d["f"][:, 0]),
                "fig6_bias_z": f"{bias[0]:.2f}",
                "pop_median_convergence_time_s": f"{np.median(t_med[pop]):.1f}",
                "pop_median_change_vs_all_s": f"{np.median(t_med[pop] - np.median(ref['t'], 0)[pop]):.1f}",  # noqa: E501
                "pop_median_accuracy": f"{np.median(np.median(d['a'], 0)[pop]):.3g}",
                "pop_median_final_error": f"{np.median(np.median(d['f'], 0)[pop]):.3g}",
                "pop_share_biased_z>4": f"{np.mean(bias[pop] > 4):.2f}",
            }  # fmt: skip
            rows.append(row)
            print(", ".join(f"{k}={v}" for k, v in row.items()), flush=True)
    write_rows(out / "rls_columns_study.csv", rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
