"""Fig. 7: identification performance over single-frequency motion states of TM1 x TM2.

Usage: python experiments/fig7_single_frequency_grid.py [--quick] [--out DIR] [--seeds 10]

Each TM's state is one sinusoid with amplitude {1e-6, 1e-5, 1e-4} m, angular frequency
2 pi/{300, 600, 900, 1200} rad/s and phase {0, pi/2, pi}: 36 states per TM, 36 x 36 =
1296 closed-loop runs (``--quick``: phase 0 only, 12 x 12 = 144).  States are numbered
``s = (a-1)*12 + (b-1)*3 + c`` (a amplitude, b frequency, c phase; the paper's printed
formula ``(a-1)*3 + (b-1)*4 + c`` is not one-to-one and is read as this lexicographic
order).  Convergence time and accuracy of k1xx (TM1) and k2xx (TM2) are written as
36 x 36 maps (row = TM1 state, column = TM2 state; the median over ``--seeds`` noise
seeds) and the trend summaries are printed as median (min-max) over the seeds.
"""

from __future__ import annotations

import argparse
import itertools
import math
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.stats import spearmanr  # noqa: E402

from tmopt.physics.excitation import MultiSine  # noqa: E402
from tmopt.physics.objectives import evaluate  # noqa: E402
from tmopt.physics.report import fmt_stats, output_dir, write_rows  # noqa: E402
from tmopt.physics.simulator import SimulationConfig, simulate  # noqa: E402

AMPLITUDES = (1e-6, 1e-5, 1e-4)
PERIODS = (300.0, 600.0, 900.0, 1200.0)
PHASES = (0.0, math.pi / 2, math.pi)


def states(quick: bool) -> list[tuple[float, float, float]]:
    phases = PHASES[:1] if quick else PHASES
    return [(a, 2 * math.pi / p, c) for a, p, c in itertools.product(AMPLITUDES, PERIODS, phases)]


def run_grid(st, seed: int, chunk: int = 216):
    """All (TM1 state, TM2 state) pairs; returns dict of (S, S) maps per parameter."""
    s = len(st)
    pairs = np.array(list(itertools.product(range(s), range(s))))
    arr = np.array(st)
    cfg = SimulationConfig(record="estimates")
    maps = {k: np.empty(s * s) for k in ("t1", "a1", "f1", "t2", "a2", "f2", "div")}
    for lo in range(0, len(pairs), chunk):  # bounded memory for theta_hat
        p = pairs[lo : lo + chunk]
        r1 = MultiSine(arr[p[:, 0], 0:1], arr[p[:, 0], 1:2], arr[p[:, 0], 2:3])
        r2 = MultiSine(arr[p[:, 1], 0:1], arr[p[:, 1], 1:2], arr[p[:, 1], 2:3])
        res = simulate(r1, r2, cfg, seed=seed)
        for idx in (0, 1):
            ev = evaluate(res, idx=idx)
            sl = slice(lo, lo + len(p))
            maps[f"t{idx + 1}"][sl] = ev["convergence_time"]
            maps[f"a{idx + 1}"][sl] = ev["convergence_accuracy"]
            maps[f"f{idx + 1}"][sl] = ev["final_accuracy"]
        maps["div"][lo : lo + len(p)] = res.diverged
    return pairs, {k: v.reshape(s, s) for k, v in maps.items()}


def trends(st, maps, tm: int) -> dict[str, float]:
    """The paper's qualitative claims as numbers for TM ``tm`` (1 or 2), one seed."""
    t, a = maps[f"t{tm}"], maps[f"a{tm}"]
    own = 0 if tm == 1 else 1  # axis of the identified TM's own state
    arr = np.array(st)
    out = {}
    for name, col, values in (("amplitude", 0, AMPLITUDES),
                              ("period", 1, [2 * math.pi / p for p in PERIODS])):  # fmt: skip
        for v in values:
            sel = np.isclose(arr[:, col], v)
            label = f"{v:g} m" if col == 0 else f"{2 * math.pi / v:g} s"
            out[f"own {name} {label}: mean time s"] = t[sel].mean() if own == 0 \
                else t[:, sel].mean()
            out[f"own {name} {label}: geo-mean accuracy"] = np.exp(np.log(
                a[sel] if own == 0 else a[:, sel]).mean())
    diag = np.diag(a)
    near = np.array([np.exp(np.log(np.r_[a[i, max(i - 1, 0):i], a[i, i + 1:i + 2]]).mean())
                     for i in range(len(st))])  # fmt: skip
    out["diagonal / row-neighbour accuracy (geo-mean ratio)"] = np.exp(np.mean(np.log(
        diag / near)))
    out["Spearman(time, accuracy)"] = spearmanr(t.ravel(), a.ravel()).statistic
    out["share converged (< 1200 s)"] = np.mean(t < 1200)
    out["fastest time s"] = t.min()
    out["best accuracy"] = a.min()
    return {k: float(v) for k, v in out.items()}


def plot(maps, path, n, seeds: int) -> None:
    fig, axes = plt.subplots(2, 2, figsize=(11, 9))
    fig.suptitle(f"Fig. 7 reproduction: median over {seeds} noise seeds")
    for row, tm in enumerate((1, 2)):
        for col, (key, label) in enumerate(((f"t{tm}", "convergence time [s]"),
                                            (f"a{tm}", "log10 convergence accuracy"))):  # fmt: skip
            data = maps[key] if key[0] == "t" else np.log10(maps[key])
            im = axes[row, col].imshow(data, origin="lower", extent=(0.5, n + 0.5, 0.5, n + 0.5))
            axes[row, col].set_title(f"k{tm}xx: {label}")
            axes[row, col].set_xlabel("TM2 state #")
            axes[row, col].set_ylabel("TM1 state #")
            fig.colorbar(im, ax=axes[row, col])
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description="Fig. 7 reproduction")
    ap.add_argument("--quick", action="store_true", help="phase 0 only (144 runs per seed)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args()
    out = output_dir("fig7_single_frequency_grid" + ("_quick" if args.quick else ""), args.out)
    st = states(args.quick)
    t0 = time.perf_counter()
    per_seed, summary = [], {1: [], 2: []}
    for seed in range(args.seeds):
        pairs, maps = run_grid(st, seed)
        per_seed.append(maps)
        for tm in (1, 2):
            summary[tm].append(trends(st, maps, tm))
    diverged = int(sum(m["div"].sum() for m in per_seed))
    print(f"{len(pairs)} closed-loop runs x {args.seeds} seeds in "
          f"{time.perf_counter() - t0:.1f} s, diverged: {diverged}")
    med = {k: np.median([m[k] for m in per_seed], axis=0) for k in per_seed[0]}
    rows = []
    for i, j in pairs:
        rows.append({"tm1_state": i + 1, "tm2_state": j + 1,
                     "A1": st[i][0], "w1": st[i][1], "phase1": st[i][2],
                     "A2": st[j][0], "w2": st[j][1], "phase2": st[j][2],
                     **{f"k{tm}xx_{name}_median": med[f"{key}{tm}"][i, j]
                        for tm in (1, 2)
                        for key, name in (("t", "time_s"), ("a", "accuracy"),
                                          ("f", "final"))}})  # fmt: skip
    write_rows(out / "fig7_grid_median.csv", rows)
    seed_rows = [{"tm": tm, "seed": s, **summary[tm][s]} for tm in (1, 2)
                 for s in range(args.seeds)]  # fmt: skip
    write_rows(out / "fig7_trends_seeds.csv", seed_rows)
    plot(med, out / "fig7_single_frequency_grid.png", len(st), args.seeds)
    for tm in (1, 2):
        print(f"k{tm}xx, median (min-max) over {args.seeds} seeds:")
        for key in summary[tm][0]:
            print(f"  {key}: {fmt_stats([d[key] for d in summary[tm]])}")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
