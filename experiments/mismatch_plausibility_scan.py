"""False refusals of the mismatch tool's plausibility checks on consistent recordings.

    python experiments/mismatch_plausibility_scan.py [--seed-base 31000] [--step 1]

Runs only :func:`tmopt.mismatch.plausibility.precheck` (no diagnosis) on the realistic set
of both simulators (:func:`mismatch_realistic.cases`: clean recordings, every catalogue
effect, pairs, every out-of-catalogue effect, glitch storms; every ``--step``-th case), and
prints per recording whether it was refused, each axis's own-readout fraction and the
smallest margin (decades) by which an axis's own readout explains its force better than
any other axis's readout (:func:`tmopt.mismatch.plausibility.loop_attribution`; a refusal
for swapped channels needs a margin below ``-SWAP_DECADES``).  Seeds 31000 on: neither the
benchmark's (40000 on) nor the development or calibration seeds.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from mismatch_realistic import build, cases


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--seed-base", type=int, default=31000)
    p.add_argument("--step", type=int, default=1, help="every STEP-th case (>= 1)")
    args = p.parse_args(argv)
    if args.step < 1 or args.seed_base < 0:
        print("error: --step must be >= 1 and --seed-base >= 0", file=sys.stderr)
        return 2
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.plausibility import loop_attribution, precheck
    from tmopt.mismatch.realistic import realistic_recording

    refused, margins, owns, n = 0, [], [], 0
    for backend in ("kernel", "foreign"):
        for c in cases(backend, args.seed_base, False)[:: args.step]:
            t0 = time.process_time()
            try:
                sc, eff, ooc, _ = build(c)
                rec, _ = realistic_recording(sc, eff, ooc, c["seed"], backend)
            except Exception as exc:  # a diverged loop is reported, not hidden
                print(f"{backend} {c['seed']} generation failed: {exc}", flush=True)
                continue
            data = data_from_recording(rec)
            verdict = precheck(data)
            frac, logr = loop_attribution(data)
            margin = min(float(np.nanmin(np.delete(logr[a], a)) - logr[a, a]) for a in range(4))
            own = float(np.nanmin(np.diag(frac)))
            n += 1
            refused += verdict.refused
            margins.append(margin)
            owns.append(own)
            truth = "+".join(i.get("name", "storm") for i in c["items"]) or "clean"
            print(f"{backend} {c['seed']} {truth} fs={sc.sample_rate:g}: "
                  f"{'REFUSED ' + verdict.reason if verdict.refused else 'ok'}; own readout "
                  f">= {own:.2f} of windows, margin {margin:.2f} decades "
                  f"({time.process_time() - t0:.1f} s)", flush=True)  # fmt: skip
    if n:
        print(f"{n} recordings: {refused} refused; own-readout fraction min {min(owns):.2f}; "
              f"margin min {min(margins):.2f} decades")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
