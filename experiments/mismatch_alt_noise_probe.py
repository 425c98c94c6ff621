"""Probe for issue 26's joint search (not part of the tool): how much does a candidate's
GLR change when the equation group's noise model is re-estimated *under the alternative*
(the candidate fitted) instead of from the residual that still holds it?

The diagnosis estimates the coloured noise model from the current residual (the null's);
an effect not yet fitted is part of that residual, raises the smoothed spectrum in its
band and is whitened down with it.  Re-estimating the noise with the candidate fitted
restores that part -- and, with no effect present, lowers the spectrum where the
candidate's best fit took noise power away, which inflates the statistic.  This script
measures both sides: on clean recordings (calibration seeds, both simulators; the
statistic's null distribution) and on chosen recordings (``--seeds``: e.g. the r6 pairs
whose second effect was missed).  It decides nothing.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 nice -n 10 \\
      python experiments/mismatch_alt_noise_probe.py --n 20
    python experiments/mismatch_alt_noise_probe.py --n 0 --seeds foreign:40088,kernel:40088 ...

Seeds of the clean set: 66000 onwards (not used elsewhere).  Per recording: the top
``--top`` equation-group candidates not selected (by GLR under the null's noise), each
with ``glr_null`` and ``glr_alt``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

SEED_BASE = 66000


def probe(backend: str, seed: int, top: int, benchmark: bool) -> dict:
    from tmopt.mismatch.diagnose import (
        Settings,
        _fit_eq,
        _Group,
        diagnose,
        evaluate,
    )
    from tmopt.mismatch.effects import EFFECTS
    from tmopt.mismatch.fit import data_from_recording, equation_target, solve
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    if benchmark:
        from mismatch_realistic import build, cases

        case = next(c for c in cases(backend, 40000, False) if c["seed"] == seed)
        sc, effects, ooc, _ = build(case)
        truth = [f"{e.name}[{e.channel}]" for e in effects]
    else:
        sc, effects, ooc, truth = draw_scenario(seed, backend), (), (), []
    rec, _ = realistic_recording(sc, effects, ooc, seed, backend)
    settings = Settings()
    dg = diagnose(data_from_recording(rec), settings)
    if dg.refused:
        return {"backend": backend, "seed": seed, "refused": dg.refused}
    data, basis, state = dg.data, dg.basis, dg.after
    chosen = {ev.candidate.key for ev, _ in dg.selected}
    evals = [e for e in evaluate(data, basis, state, settings, chosen)
             if e.candidate.group == "equation" and e.candidate.twin is None
             and e.candidate.effect in EFFECTS and not EFFECTS[e.candidate.effect].profiled]
    evals.sort(key=lambda e: -e.glr)
    target = equation_target(data, basis)
    kind = "smoothed" if settings.noise == "coloured" else "white"
    out = []
    for ev in evals[:top]:
        cols = ev.candidate.columns
        _, noise1 = _fit_eq(target, state.eq_cols + cols, state.red, data.layout, data.fs, kind)
        fit0 = solve(target, state.eq_cols, noise1.whiten)
        lam = _Group(None, state.eq_cols, fit0, noise1.whiten).glr(cols)
        out.append({"key": ev.candidate.key, "glr_null": ev.glr, "glr_alt": lam,
                    "dof": ev.dof, "trials": ev.candidate.trials})  # fmt: skip
    return {"backend": backend, "seed": seed, "truth": truth,
            "selected": sorted(chosen), "candidates": out}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=20, help="clean seeds per simulator (>= 0)")
    ap.add_argument("--seeds", default="", help="benchmark recordings BACKEND:SEED,...")
    ap.add_argument("--top", type=int, default=6, help="candidates re-tested (>= 1)")
    ap.add_argument("--out", default="experiments/out/mismatch_alt_noise_probe")
    a = ap.parse_args(argv)
    if a.n < 0 or a.top < 1:
        print("error: --n must be >= 0 and --top >= 1", file=sys.stderr)
        return 2
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    jobs = [(b, SEED_BASE + i, False) for i in range(a.n) for b in ("kernel", "foreign")]
    for item in filter(None, a.seeds.split(",")):
        b, _, s = item.partition(":")
        if b not in ("kernel", "foreign") or not s.isdigit():
            print(f"error: --seeds item {item!r} is not kernel:SEED or foreign:SEED",
                  file=sys.stderr)  # fmt: skip
            return 2
        jobs.append((b, int(s), True))
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "rows.jsonl"
    done = {(r["backend"], r["seed"]) for r in map(json.loads, path.open())} \
        if path.exists() else set()  # fmt: skip
    with path.open("a") as fh:
        for b, s, bench in jobs:
            if (b, s) in done:
                continue
            row = probe(b, s, a.top, bench)
            fh.write(json.dumps(row, default=float) + "\n")
            fh.flush()
            print(json.dumps(row, default=float), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
