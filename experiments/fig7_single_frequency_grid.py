"""Fig. 7: identification performance over single-frequency motion states of TM1 x TM2.

Usage: python experiments/fig7_single_frequency_grid.py [--quick] [--out DIR] [--seed 0]

Each TM's state is one sinusoid with amplitude {1e-6, 1e-5, 1e-4} m, angular frequency
2 pi/{300, 600, 900, 1200} rad/s and phase {0, pi/2, pi}: 36 states per TM, 36 x 36 =
1296 closed-loop runs (``--quick``: phase 0 only, 12 x 12 = 144).  States are numbered
``s = (a-1)*12 + (b-1)*3 + c`` (a amplitude, b frequency, c phase; the paper's printed
formula ``(a-1)*3 + (b-1)*4 + c`` is not one-to-one and is read as this lexicographic
order).  Convergence time and accuracy of k1xx (TM1) and k2xx (TM2) are written as
36 x 36 maps (row = TM1 state, column = TM2 state) with the trend summaries printed.
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
from tmopt.physics.report import output_dir, write_rows  # noqa: E402
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


def trends(st, maps, tm: int) -> None:
    """Print the paper's qualitative claims as numbers for TM ``tm`` (1 or 2)."""
    t, a = maps[f"t{tm}"], maps[f"a{tm}"]
    own = 0 if tm == 1 else 1  # axis of the identified TM's own state
    arr = np.array(st)
    for name, col, values in (("amplitude", 0, AMPLITUDES),
                              ("period", 1, [2 * math.pi / p for p in PERIODS])):  # fmt: skip
        parts = []
        for v in values:
            sel = np.isclose(arr[:, col], v)
            tt = t[sel].mean() if own == 0 else t[:, sel].mean()
            aa = np.exp(np.log(a[sel] if own == 0 else a[:, sel]).mean())
            label = f"{v:g}" if col == 0 else f"{2 * math.pi / v:g}s"
            parts.append(f"{label}: T={tt:.0f}s acc={aa:.2e}")
        print(f"  TM{tm} own {name:9s} -> " + "; ".join(parts))
    diag = np.diag(a)
    near = np.array([np.exp(np.log(np.r_[a[i, max(i - 1, 0):i], a[i, i + 1:i + 2]]).mean())
                     for i in range(len(st))])  # fmt: skip
    print(f"  TM{tm} accuracy on the diagonal (same state) / its row neighbours: geometric "
          f"mean ratio {np.exp(np.mean(np.log(diag / near))):.2f}")  # fmt: skip
    rho = spearmanr(t.ravel(), a.ravel()).statistic
    print(f"  TM{tm} Spearman(convergence time, accuracy) = {rho:.2f}; "
          f"converged (< 1200 s): {np.mean(t < 1200):.0%}; "
          f"time range {t.min():.0f}..{t.max():.0f} s, accuracy {a.min():.2e}..{a.max():.2e}")


def plot(maps, path, n) -> None:
    fig, axes = plt.subplots(2, 2, figsize=(11, 9))
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
    ap.add_argument("--quick", action="store_true", help="phase 0 only (144 runs)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    out = output_dir("fig7_single_frequency_grid" + ("_quick" if args.quick else ""), args.out)
    st = states(args.quick)
    t0 = time.perf_counter()
    pairs, maps = run_grid(st, args.seed)
    print(f"{len(pairs)} closed-loop runs in {time.perf_counter() - t0:.1f} s, "
          f"diverged: {int(maps['div'].sum())}")
    rows = []
    for i, j in pairs:
        rows.append({"tm1_state": i + 1, "tm2_state": j + 1,
                     "A1": st[i][0], "w1": st[i][1], "phase1": st[i][2],
                     "A2": st[j][0], "w2": st[j][1], "phase2": st[j][2],
                     "k1xx_time_s": maps["t1"][i, j], "k1xx_accuracy": maps["a1"][i, j],
                     "k1xx_final": maps["f1"][i, j], "k2xx_time_s": maps["t2"][i, j],
                     "k2xx_accuracy": maps["a2"][i, j],
                     "k2xx_final": maps["f2"][i, j]})  # fmt: skip
    write_rows(out / "fig7_grid.csv", rows)
    plot(maps, out / "fig7_single_frequency_grid.png", len(st))
    for tm in (1, 2):
        trends(st, maps, tm)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
