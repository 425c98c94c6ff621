"""Null of the generic line candidate with its frequency read off the whole record.

``Settings.line_refine`` (docs/mismatch.md 9.38) searches the line's frequency on a grid
1/(4 T) apart within one bin of the longest gap-free segment's periodogram peak, and
multiplies its trials by T/T_seg.  Its cost is on clean recordings: does the refined
line reach the catalogue's level at the first step more often than the grid's?  Per clean
flight-like calibration recording (``--seed-base``, ``--n`` per simulator), both ways:
the line candidate's frequency, GLR, trials, Holm p, and the first step's best.

Run: ``python experiments/mismatch_line_refine_null.py --seed-base 37700 --n 60``
(stop 63's registered set: seeds 37700-37759, both simulators).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def first_step(rec, refine: bool) -> dict:
    """The line candidate's reading and the first step's best, with or without refinement."""
    from tmopt.mismatch.diagnose import Settings, evaluate, fit_state, prepare
    from tmopt.mismatch.fit import data_from_recording

    settings = Settings(line_refine=refine)
    data, basis = prepare(data_from_recording(rec))
    state = fit_state(data, basis, [], [], False, settings)
    evals = evaluate(data, basis, state, settings, set())
    line = [e for e in evals if (e.candidate.fixed or {}).get("feature") == "line"]
    best = min(evals, key=lambda e: e.p_holm)
    out = {"best": best.candidate.key, "best_p_holm": best.p_holm}
    if line:
        e = line[0]
        out.update(line_channel=e.candidate.channel, line_hz=e.candidate.fixed["frequency_hz"],
                   line_glr=e.glr, line_trials=e.candidate.trials, line_p_holm=e.p_holm)
    return out


def job(job: dict) -> dict:
    from mismatch_realistic import clean_recording

    rec = clean_recording(job["seed"], job["backend"])
    return {**job, "grid": first_step(rec, False), "refined": first_step(rec, True)}


def summarise(rows: list[dict], alpha: float) -> None:
    print(f"{len(rows)} clean recordings; the line candidate at the catalogue's level "
          f"(Holm p < {alpha:g}) at the first step:")
    for way in ("grid", "refined"):
        hits = [r for r in rows if r[way].get("line_p_holm", 1.0) < alpha]
        best = [r for r in rows if r[way]["best_p_holm"] < alpha]
        print(f"  {way}: {len(hits)} (" + ", ".join(f"{r['backend']} {r['seed']}" for r in hits)
              + f"); any candidate of the step: {len(best)}")
    moved = [r for r in rows if "line_hz" in r["grid"] and "line_hz" in r["refined"]]
    glr = [(r["refined"]["line_glr"], r["grid"]["line_glr"]) for r in moved]
    if glr:
        import numpy as np

        gain = np.array([a - b for a, b in glr])
        print(f"  GLR refined - grid over {len(glr)}: median {np.median(gain):.2f}, "
              f"max {gain.max():.2f}")


def main(argv=None) -> int:
    from mismatch_realistic import calibration_cli, streamed_rows

    from tmopt.mismatch.calibration import FAMILY_ALPHA

    a = calibration_cli(__doc__.splitlines()[0], 60, "experiments/out/line_refine_null.jsonl",
                        argv, {"--seed-base": {"type": int, "default": 37700}})
    if a is None:
        return 2
    todo = [{"set": "null", "backend": b, "seed": a.seed_base + i}
            for i in range(a.n) for b in ("kernel", "foreign")]  # fmt: skip
    summarise(streamed_rows(Path(a.out), todo, job, a.jobs), FAMILY_ALPHA)
    return 0


if __name__ == "__main__":
    sys.exit(main())
