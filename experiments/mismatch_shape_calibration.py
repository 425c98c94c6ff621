"""Calibration of a drift's shape check (``SHAPE_ALPHA``) on flight-like recordings.

    python experiments/mismatch_shape_calibration.py [--effect bias_drift|stiffness_drift] \\
        [--n 20] [--jobs 1] [--seed-base S] [--no-true-position] [--out DIR]

A selected ``bias_drift`` or ``stiffness_drift`` is reported ambiguous, its channel
unexplained, when Legendre P2 + P3 of time (times the axis' position, for the stiffness)
added to the final model are significant at ``SHAPE_ALPHA``
(:meth:`tmopt.mismatch.effects.base.Effect.curvature_in_time`).  Two sets, both
simulators, seeds 33000 onwards for the bias drift and 34000 onwards for the stiffness
drift (never a benchmark set's, 40000 on, nor the development seeds < 20000):

* **null** -- a true *linear* drift at SNR 20 and 60 (alternating) in each recording's
  own coloured noise: the share of them the check flags is its false-misfit rate (the
  price in attribution); it should be near ``SHAPE_ALPHA`` if the coloured noise model
  holds where the check's columns live;
* **power** -- changes the catalogue has no name for, SNR 40: for the bias a 1e-4 Hz
  modulation and a thermal relaxation, for the stiffness a stiffness step; the share
  that is no longer named the drift with confidence.

The check is P2 + P3 and the searched step and relaxation on the drift's axis (a
stiffness step for the stiffness drift; :meth:`tmopt.mismatch.effects.base.Effect.
shape_search`, Bonferroni over the checks, docs/mismatch.md 9.17); each row keeps every
check's own p-value (``checks``) and the fixed check's alone (``fixed_p``).

``--no-true-position``: the stiffness acts on the readout as recorded
(``Settings(true_position=False)``, docs/mismatch.md 9.19), for a paired measure of what
the true position costs or gains the check.

Prints each recording's shape-check p-value and the two rates.  The level is a plain test
level fixed before this run (0.01), not tuned on it.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Per checked effect: its seed base and the out-of-catalogue changes of its power set.
EFFECTS = {"bias_drift": (33000, ("bias_modulation", "thermal_relaxation")),
           "stiffness_drift": (34000, ("stiffness_step",))}


def jobs(n: int, effect: str = "bias_drift", seed_base: int | None = None,
         true_position: bool = True) -> list[dict]:  # fmt: skip
    base, power = EFFECTS[effect]
    base = base if seed_base is None else seed_base
    out = []
    for i in range(n):
        for backend in ("kernel", "foreign"):
            snr = 20.0 if i % 2 == 0 else 60.0
            out.append({"set": "null", "backend": backend, "category": "catalogue",
                        "seed": base + i, "effect": effect,
                        "items": [{"kind": "effect", "name": effect, "snr": snr}]})
            out.append({"set": "power", "backend": backend, "category": "out-of-catalogue",
                        "seed": base + 500 + i, "effect": effect,
                        "items": [{"kind": "ooc", "name": power[i % len(power)], "snr": 40.0}]})
    for j in out:
        j["true_position"] = true_position
    return out


def run(job: dict) -> dict:
    from mismatch_realistic import diagnosed_case

    from tmopt.mismatch.diagnose import Settings, shape_misfits

    t0 = time.process_time()
    row = {k: job[k] for k in ("set", "backend", "seed")}
    row["truth"] = job["items"][0]["name"]
    row["true_position"] = job.get("true_position", True)
    dg, snrs, error = diagnosed_case(job, Settings(true_position=row["true_position"]))
    if error:
        return {**row, "error": error}
    row["snr"] = snrs[0]
    row["selected"] = [ev.candidate.key for ev, _ in dg.selected]
    checks = [] if dg.refused else shape_misfits(dg.data, dg.basis, dg.after, dg.selected, 1.0,
                                                 alternative=True)  # fmt: skip
    drift = [c for c in checks if c["key"].startswith(job.get("effect", "bias_drift"))]
    row["shape_p"] = drift[0]["p_value"] if drift else None
    row["shape_glr"] = drift[0]["glr"] if drift else None
    row["shape_glr_alt"] = drift[0]["glr_alt"] if drift else None
    # each check's own p-value before Bonferroni: the fixed P2 + P3 and the searched shapes
    row["checks"] = drift[0]["checks"] if drift else None  # with the in-place comparison
    row["fixed_p"] = drift[0]["checks"][0]["p_value"] if drift else None
    row["flagged"] = [m["key"] for m in dg.misfits]
    row["cpu_s"] = time.process_time() - t0
    return row


def main(argv=None) -> int:
    from mismatch_realistic import calibration_cli, streamed_rows

    a = calibration_cli(__doc__.splitlines()[0], 20, "experiments/out/mismatch_shape_calibration",
                        argv, {"--effect": {"choices": tuple(EFFECTS), "default": "bias_drift"},
                               "--seed-base": {"type": int, "default": None,
                                               "help": "first null seed (power: +500); "
                                                       "default the effect's own"},
                         "--no-true-position": {"action": "store_true",
                                                "help": "the stiffness on the readout as "
                                                        "recorded (a paired arm)"}})  # fmt: skip
    if a is None:
        return 2
    if a.seed_base is not None and not 20000 <= a.seed_base < 40000:
        print(f"--seed-base must be in [20000, 40000) (calibration seeds, never a "
              f"benchmark's); got {a.seed_base}", file=sys.stderr)  # fmt: skip
        return 2
    rows = streamed_rows(Path(a.out) / "rows.jsonl",
                         jobs(a.n, a.effect, a.seed_base, not a.no_true_position), run,
                         a.jobs)  # fmt: skip
    from tmopt.mismatch.calibration import SHAPE_ALPHA

    for s in ("null", "power"):
        for b in ("kernel", "foreign"):
            rs = [r for r in rows if r["set"] == s and r["backend"] == b and "error" not in r]
            named = [r for r in rs if r["shape_p"] is not None]
            flag = [r for r in named if r["shape_p"] < SHAPE_ALPHA]
            fixed = [r for r in named if (r.get("fixed_p") or 1.0) < SHAPE_ALPHA]
            print(f"{s:5s} {b:7s}: {len(rs)} recordings, {a.effect} selected in {len(named)}, "
                  f"shape check flags {len(flag)} (p < {SHAPE_ALPHA}; P2 + P3 alone: "
                  f"{len(fixed)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
