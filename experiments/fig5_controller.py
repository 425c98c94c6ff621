"""Fig. 5: FRBF-PID vs PID control error for pulse, sine and chirp references (1e-5 m).

Usage: python experiments/fig5_controller.py [--out DIR] [--seed 0]

The TM1 sensitive axis tracks each reference (TM2 at rest) in the full closed loop of
Table 1; the control error is ``reference - true x1``.  Prints, per signal and controller,
the maximum error, the time after which |e| stays below 0.2 % of the amplitude (the
paper's claim for sine and chirp: < 1 min), and the steady error (max |e| for t >= 60 s,
for the pulse over the second half of each pulse).
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tmopt.physics.report import output_dir, write_csv, write_rows  # noqa: E402
from tmopt.physics.simulator import SimulationConfig, simulate  # noqa: E402

AMPLITUDE = 1e-5


def references(t: np.ndarray) -> dict[str, np.ndarray]:
    """Pulse train (high for the first 300 s of every 600 s), sine of period 300 s, and a
    linear chirp sweeping 1/1200 Hz -> 1/100 Hz over the run; all start at 0 or step at 0."""
    f0, f1, T = 1 / 1200, 1 / 100, t[-1] + (t[1] - t[0])
    return {
        "pulse": AMPLITUDE * ((t % 600.0) < 300.0),
        "sine": AMPLITUDE * np.sin(2 * np.pi * t / 300.0),
        "chirp": AMPLITUDE * np.sin(2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * T))),
    }


def settle_time(t: np.ndarray, err: np.ndarray, tol: float) -> float:
    """Time after which |err| <= tol until the end (inf if it never settles)."""
    bad = np.nonzero(np.abs(err) > tol)[0]
    if bad.size == 0:
        return 0.0
    return float(t[bad[-1] + 1]) if bad[-1] + 1 < t.size else float("inf")


def main() -> None:
    ap = argparse.ArgumentParser(description="Fig. 5 reproduction")
    ap.add_argument("--out", default=None)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    out = output_dir("fig5_controller", args.out)
    cfg = SimulationConfig()
    t = np.arange(cfg.n_steps) / cfg.sample_rate
    refs = references(t)
    ref1 = np.stack(list(refs.values()))
    ref2 = np.zeros_like(ref1)
    errors, rows = {"time": t}, []
    for ctl in ("frbf_pid", "pid"):
        res = simulate(ref1, ref2, SimulationConfig(controller=ctl), seed=args.seed)
        for i, name in enumerate(refs):
            err = ref1[i] - res.x1_true[i]
            errors[f"{name}_{ctl}"] = err
            if name == "pulse":  # steady: second half of each 300 s plateau
                steady = np.abs(err[(t % 300.0) >= 150.0]).max()
                settle = settle_time(t[:3000], err[:3000], 0.002 * AMPLITUDE)
            else:
                steady = np.abs(err[t >= 60.0]).max()
                settle = settle_time(t, err, 0.002 * AMPLITUDE)
            rows.append({"signal": name, "controller": ctl,
                         "max_error_m": f"{np.abs(err).max():.3e}",
                         "settle_0p2pct_s": f"{settle:.1f}",
                         "steady_error_m": f"{steady:.3e}",
                         "steady_error_pct_of_amplitude": f"{100 * steady / AMPLITUDE:.4f}",
                         "diverged": bool(res.diverged[i])})  # fmt: skip
    write_csv(out / "fig5_errors.csv", errors)
    write_rows(out / "fig5_summary.csv", rows)
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    for ax, name in zip(axes, refs):
        for ctl, style in (("pid", "C1--"), ("frbf_pid", "C0-")):
            ax.plot(t, errors[f"{name}_{ctl}"], style, lw=0.8, label=ctl.upper().replace("_", "-"))
        ax.set_ylabel(f"{name} error [m]")
        ax.legend(loc="upper right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Fig. 5 reproduction: control error, amplitude 1e-5 m")
    fig.tight_layout()
    fig.savefig(out / "fig5_controller.png", dpi=120)
    for r in rows:
        print(", ".join(f"{k}={v}" for k, v in r.items()))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
