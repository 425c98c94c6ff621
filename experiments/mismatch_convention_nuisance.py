"""The accelerometer-convention test with and without the selected effects as nuisance.

    python experiments/mismatch_convention_nuisance.py [--seeds 17020-17031] [--gain 4e-3]

For development seeds, 1200 s recordings with an actuation gain on x1 -- foreign with
each convention (``mean``, ``held``) and kernel (always ``held``) --: the convention that
:func:`tmopt.mismatch.fit.choose_acc_convention` picks from the nominal Eq. 10 (what the
diagnosis did before stop 35) and with the gain's column as nuisance (what the redo with
the final model does, docs/mismatch.md 9.4), each as right / wrong / undecided (the LR
below DECIDE_LR: the kinematic group or the default ``held`` then picks).
"""

from __future__ import annotations

import argparse
import sys


def probe(seed: int, backend: str, conv: str, gain: float) -> dict:
    from tmopt.mismatch.diagnose import prepare
    from tmopt.mismatch.effects import Injection
    from tmopt.mismatch.fit import Column, axis_column, choose_acc_convention, data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    sc = draw_scenario(seed, backend, duration=1200.0, acc_convention=conv, gaps=())
    rec, _ = realistic_recording(sc, [Injection("actuation_gain", gain, "x1")], [], seed,
                                 backend)  # fmt: skip
    data, basis = prepare(data_from_recording(rec))
    truth = conv if backend == "foreign" else "held"  # the kernel's accelerometer is held
    gcol = Column("gain", axis_column(basis, 0, data.force[0]))
    out = {"seed": seed, "backend": backend, "truth": truth}
    for key, nuisance in (("nominal", []), ("with the gain", [gcol])):
        c, info = choose_acc_convention(data, data.stiffness, nuisance)
        decided = bool(info.get("decided")) and "equation" in str(info.get("by", ""))
        out[key] = "undecided" if not decided else ("right" if c == truth else "WRONG")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawTextHelpFormatter)  # fmt: skip
    ap.add_argument("--seeds", default="17020-17031", help="first-last development seeds")
    ap.add_argument("--gain", type=float, default=4e-3)
    a = ap.parse_args(argv)
    try:
        lo, hi = (int(v) for v in a.seeds.split("-"))
    except ValueError:
        print(f"error: --seeds must be FIRST-LAST; got {a.seeds!r}", file=sys.stderr)
        return 2
    if not (0 <= lo <= hi < 20000) or not 0 < a.gain < 0.1:
        print("error: --seeds within 0-19999 (development), --gain in (0, 0.1)",
              file=sys.stderr)  # fmt: skip
        return 2
    rows = []
    for seed in range(lo, hi + 1):
        for backend, conv in (("foreign", "mean"), ("foreign", "held"), ("kernel", "held")):
            try:
                rows.append(probe(seed, backend, conv, a.gain))
            except Exception as exc:  # noqa: BLE001 - a diverged loop is reported, not hidden
                print(f"{seed} {backend} {conv}: generation failed ({exc})", flush=True)
                continue
            r = rows[-1]
            print(f"{seed} {backend} truth {r['truth']}: nominal {r['nominal']}, "
                  f"with the gain {r['with the gain']}", flush=True)  # fmt: skip
    for key in ("nominal", "with the gain"):
        n = {v: sum(r[key] == v for r in rows) for v in ("right", "WRONG", "undecided")}
        print(f"{key}: {n['right']} right, {n['WRONG']} wrong, {n['undecided']} undecided "
              f"(equation group) of {len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
