"""Check of actuation_delay's kinematic twin against both simulators (issue 26, round 8).

A delay ``tau < h`` switches the applied force ``tau`` into every step.  The step-mean
accelerometer reports the mean force; the positions also see *when* in the step the force
changed: ``tmopt.mismatch.fit.switch_series`` derives the kinematic residual
``-(tau (h - tau)/2) (f_n - 2 f_(n-1) + f_(n-2))`` (exact ZOH integration of a force that
is E on ``[t_n, t_n + tau)`` and L after; docs/mismatch.md 9.8).

Per seed: the same scenario (no gaps, no glitches, same noise draw) simulated clean and
with a delay scaled to the scaler's SNR 40; both prepared as the tool does
(``diagnose.prepare``: clocks aligned, stiffness and convention); the *measured* change of
the kinematic residual on the delayed axis (all rows but the first, which needs the command
before the record) is regressed on the predicted series.  Printed:
fitted/predicted amplitude (1 = the derivation), the fraction of the change it explains
(R^2), and the change on the other axes (should be ~0).  Development seeds 16000+ only.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 nice -n 10 \\
      python experiments/mismatch_delay_twin_check.py --n 6
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

SEED_BASE = 16000


def check(backend: str, seed: int) -> dict:
    from tmopt.mismatch.diagnose import prepare
    from tmopt.mismatch.effects import Injection
    from tmopt.mismatch.fit import AXES, data_from_recording, kinematic_target, switch_series
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording, scale_to_snr

    sc = replace(draw_scenario(seed, backend), gaps=(), glitches=())
    ch = AXES[seed % 2]
    inj, rho = scale_to_snr(sc, Injection("actuation_delay", 3.3e-4, ch), 40.0, seed, backend)
    rec0, _ = realistic_recording(sc, (), (), seed, backend, gaps=False)
    rec1, _ = realistic_recording(sc, [inj], (), seed, backend, gaps=False)
    d1, _ = prepare(data_from_recording(rec1))
    d0, _ = prepare(data_from_recording(rec0))
    d0.stiffness, d0.acc_convention = d1.stiffness, d1.acc_convention  # same kinematics
    i, h, tau = AXES.index(ch), d1.dt, inj.magnitude
    change = kinematic_target(d1) - kinematic_target(d0)
    pred = (tau / h) * (1 - tau / h) * switch_series(d1, i)
    # row 0 (n = 1) needs f_(-1), the command before the record: the series leaves it 0
    c, p = change[i, 1:], pred[1:]
    amp = float(c @ p / (p @ p))
    r2 = 1.0 - float(np.sum((c - amp * p) ** 2) / np.sum(c**2))
    others = max(float(np.std(change[j])) for j in range(4) if j != i)
    return {"backend": backend, "seed": seed, "axis": ch, "fs": d1.fs, "tau": tau,
            "tau_h": tau / h, "snr": rho, "stamp": sc.force_stamp,
            "convention": d1.acc_convention, "amplitude": amp, "r2": r2,
            "change_rms": float(np.std(change[i])), "others_rms": others}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=6, help="seeds per simulator (1-200)")
    args = ap.parse_args(argv)
    if not 1 <= args.n <= 200:
        ap.error(f"--n must be in [1, 200]; got {args.n}")
    print("backend seed axis fs tau[s] tau/h snr stamp conv | amplitude R^2 change_rms others_rms")
    for backend in ("foreign", "kernel"):
        for seed in range(SEED_BASE, SEED_BASE + args.n):
            r = check(backend, seed)
            print(f"{r['backend']} {r['seed']} {r['axis']} {r['fs']:g} {r['tau']:.3g} "
                  f"{r['tau_h']:.2g} {r['snr']:.1f} {r['stamp']} {r['convention']} | "
                  f"{r['amplitude']:.4f} {r['r2']:.6f} {r['change_rms']:.3g} "
                  f"{r['others_rms']:.2g}", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
