"""Null of the kinematic test of a cross-axis readout term whose source axis is not excited.

A kinematic candidate ``disp:a<-b`` (sensing cross-talk) regresses readout a's kinematic
residual on ``h^2 acc_b``.  Its instrument is acc_b's part at b's excitation tones (the
reference cannot carry the loop's noise); an unexcited b has no such part and the candidate
was untestable, so a cross-talk from an axis that moves only with its own noise was never
seen (80000 set: 4 of 5 cross-talk misses).  For b != a, acc_b carries b's noise, not a's:
the plain regressor (OLS, instrument = itself) is exogenous *if* the loops do not share
noise.  Whether they do is this script's question, asked of clean recordings of both
backends: per unexcited-source candidate in the first step, the Wald statistic against
chi^2(1), and the diagnosis' false alarms with the rule on and off.

Run: ``python experiments/mismatch_open_source_null.py --seed-base 17200 --n 32 --jobs 2``
(seeds: the realistic set's clean cases, ``base + 0 .. n-1`` per backend).

``--excited`` asks the same of an *excited* source axis (stop 42, ``EXCITED_SOURCE_OLS``:
the plain regressor instead of its tone part): the rule switched is that one, the
statistics are those of the cross-axis candidates whose source carries tones.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def one(args: tuple[str, int, int, bool]) -> dict:
    from mismatch_realistic import build, cases

    import tmopt.mismatch.effects.base as base
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import realistic_recording

    backend, seed, seed_base, excited = args
    rule = "EXCITED_SOURCE_OLS" if excited else "UNEXCITED_SOURCE_OLS"
    case = next(c for c in cases(backend, seed_base, False) if c["seed"] == seed)
    sc, effects, ooc, _ = build(case)
    rec, _ = realistic_recording(sc, effects, ooc, seed, backend)
    out = {"backend": backend, "seed": seed, "rule": rule}
    for flag in (False, True):
        setattr(base, rule, flag)
        dg = diagnose(data_from_recording(rec))
        out[f"found_{int(flag)}"] = [s[0].candidate.key for s in dg.selected]
        out[f"unexplained_{int(flag)}"] = bool(dg.unexplained)
        d = dg.data
        open_axes = [i for i in range(4) if not d.tones(i)]
        out["unexcited"] = open_axes
        # the rule's candidates' statistics, with it ("stats") and without ("stats_off")
        out["stats" if flag else "stats_off"] = [
            (e.candidate.key, e.glr) for e in dg.steps[0]
            if e.candidate.effect == "sensing_cross_talk"
            and (_source(e.candidate.channel) in open_axes) != excited]  # fmt: skip
    setattr(base, rule, True)
    return out


def _source(channel: str) -> int:
    from tmopt.mismatch.effects.base import AXES

    return AXES.index(channel.split("<-")[1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed-base", type=int, default=17200)
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default="experiments/out/mismatch_open_source_null.jsonl")
    ap.add_argument("--excited", action="store_true",
                    help="switch and measure the excited-source rule (EXCITED_SOURCE_OLS)")
    a = ap.parse_args()
    if not 1 <= a.n <= 32:
        sys.exit(f"--n must be in [1, 32] (the clean cases of one realistic set); got {a.n}")
    work = [(b, a.seed_base + i, a.seed_base, a.excited) for b in ("kernel", "foreign")
            for i in range(a.n)]  # fmt: skip
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    rows = []
    with ProcessPoolExecutor(a.jobs) as ex, open(a.out, "w") as fh:
        for i, r in enumerate(ex.map(one, work), 1):
            rows.append(r)
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(f"[{i}/{len(work)}] {r['backend']} {r['seed']} unexcited {r['unexcited']} "
                  f"off {r['found_0']} {r['unexplained_0']} on {r['found_1']} "
                  f"{r['unexplained_1']}", flush=True)  # fmt: skip
    for label, field in (("rule on", "stats"), ("rule off", "stats_off")):
        print(label + ":")
        _tails(rows, field, a.excited)
    _false_alarms(rows)


def _tails(rows: list[dict], field: str, excited: bool) -> None:
    from scipy import stats

    glr = {"disp": [], "acc": []}
    for r in rows:
        for key, g in r[field]:
            glr["disp" if "[disp:" in key else "acc"].append(g)
    for kind, g in glr.items():
        if not g:
            continue
        ks = stats.kstest(g, stats.chi2(1).cdf)
        tail = {q: sum(x > stats.chi2.isf(q, 1) for x in g) for q in (0.05, 0.01, 0.001)}
        which = "excited" if excited else "unexcited"
        print(f"{kind}: {len(g)} {which}-source statistics; KS vs chi2(1) p = {ks.pvalue:.3g}; "
              + ", ".join(f"> {q:g} level: {n} (expected {q * len(g):.1f})"
                          for q, n in tail.items())
              + f"; max {max(g):.3g}")  # fmt: skip
    print("mean statistic", {k: (sum(v) / len(v) if v else math.nan) for k, v in glr.items()})


def _false_alarms(rows: list[dict]) -> None:
    for flag in (0, 1):
        fa = sum(bool(r[f"found_{flag}"]) or r[f"unexplained_{flag}"] for r in rows)
        print(f"rule {'on ' if flag else 'off'}: false alarms {fa}/{len(rows)}")


if __name__ == "__main__":
    main()
