"""False alarms on clean flight-like recordings as gaps multiply.

    python experiments/mismatch_gap_calibration.py [--n 15] [--gaps 0,8,16] [--jobs 2] \\
        [--seed-base 38200] [--rails-pattern] [--out DIR]

The benchmark's recordings hold 0-4 gaps (``realistic._draw_gaps``).  A record cut into
many pieces -- telemetry losses, glitches masked by hand, the samples of a saturated
sensor left out (docs/mismatch.md 9.22) -- is analysed on its gap-free segments, each
whitened on its own.  Here each clean recording of both simulators (calibration seeds
from ``--seed-base``; the benchmark's sets start at 40000) is diagnosed with its own gaps
taken out and ``K`` NaN runs of 2-30 s (log-uniform) put at uniform random times instead,
for each ``K`` of ``--gaps`` (the same scenario and noise for every K, only the gaps
differ: a paired comparison).  Prints
the false-alarm rate per K with its 95 % interval, the median number and length of the
segments analysed, and what raised each alarm.  Rows stream to ``gap_rows.jsonl``
(resumable).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from mismatch_calibration import clopper_pearson  # noqa: E402

GAP_SECONDS = (2.0, 30.0)


def random_gaps(k: int, duration: float, seed: int) -> tuple[tuple[float, float, str], ...]:
    """``k`` NaN runs (start s, stop s, "nan") of log-uniform length in GAP_SECONDS at
    uniform random times of a ``duration`` s record (they may overlap)."""
    rng = np.random.default_rng([seed, k, 7])
    out = []
    for _ in range(k):
        length = float(np.exp(rng.uniform(*np.log(GAP_SECONDS))))
        t0 = float(rng.uniform(0.0, max(duration - length, 0.0)))
        out.append((t0, t0 + length, "nan"))
    return tuple(sorted(out))


def job(spec: dict) -> dict:
    from mismatch_realistic import _stat

    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording
    from tmopt.mismatch.report import build_report

    backend, seed, k = spec["backend"], spec["seed"], spec["k"]
    sc = draw_scenario(seed, backend)
    sc = replace(sc, gaps=random_gaps(k, sc.duration, seed))
    rec, _ = realistic_recording(sc, (), (), seed, backend)
    data = data_from_recording(rec)
    dg = diagnose(data)
    lengths = [b - a for a, b in data.segments]
    row = {"backend": backend, "seed": seed, "k": k, "segments": len(lengths),
           "median_segment": float(np.median(lengths)) if lengths else 0.0,
           "fraction_used": data.usage.get("fraction_used"), "refused": dg.refused or ""}
    if dg.refused:
        return {**row, "false_alarm": None, "raised": []}
    rep = build_report(dg)
    raised = [{"what": e["name"], "channel": e["channel"], **_stat(e["evidence"])}
              for e in rep["effects"]]
    raised += [{"what": f["feature"], "channel": f["channel"], **_stat(f.get("evidence", {}))}
               for f in rep.get("features", [])]  # fmt: skip
    return {**row, "false_alarm": bool(rep.get("mismatch_detected")), "raised": raised,
            "unexplained_channels": (rep.get("unexplained_at") or {}).get("channels", [])}


def summary(rows: list[dict], ks: list[int]) -> str:
    lines = ["| gaps added | false alarms | rate | 95 % interval | median segments | "
             "median segment length [samples] | refused |", "|---|---|---|---|---|---|---|"]
    for k in ks:
        sel = [r for r in rows if r["k"] == k]
        ok = [r for r in sel if r["false_alarm"] is not None]
        n_fa = sum(r["false_alarm"] for r in ok)
        lo, hi = clopper_pearson(n_fa, len(ok)) if ok else (float("nan"),) * 2
        lines.append(f"| {k} | {n_fa}/{len(ok)} | {n_fa / max(len(ok), 1):.3f} | "
                     f"[{lo:.3f}, {hi:.3f}] | {np.median([r['segments'] for r in sel]):.0f} | "
                     f"{np.median([r['median_segment'] for r in sel]):.0f} | "
                     f"{sum(bool(r['refused']) for r in sel)} |")  # fmt: skip
    lines += ["", "Alarms:", ""]
    for r in sorted(rows, key=lambda r: (r["k"], r["backend"], r["seed"])):
        if r.get("false_alarm"):
            what = "; ".join(f"{x['what']}[{x['channel']}] GLR {x['glr'] or float('nan'):.1f}"
                             for x in r["raised"]) or "unexplained"
            lines.append(f"- K={r['k']} {r['backend']} {r['seed']} ({r['segments']} segments): "
                         f"{what} {r.get('unexplained_channels') or ''}")  # fmt: skip
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--n", type=int, default=15, help="clean recordings per simulator")
    p.add_argument("--gaps", default="0,8,16", help="numbers of gaps to add, comma-separated")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--seed-base", type=int, default=38200,
                   help="first calibration seed, in [0, 40000) (40000 on are the benchmark's)")
    p.add_argument("--out", default="experiments/out/mismatch_gap_calibration")
    a = p.parse_args(argv)
    try:
        ks = [int(k) for k in a.gaps.split(",")]
    except ValueError:
        ks = [-1]
    if a.n < 1 or a.jobs < 1 or min(ks) < 0:
        print("error: --n and --jobs must be >= 1 and --gaps non-negative integers",
              file=sys.stderr)  # fmt: skip
        return 2
    if not 0 <= a.seed_base < 40000 - a.n:
        print("error: --seed-base must be in [0, 40000 - n) (40000 on are the benchmark's)",
              file=sys.stderr)  # fmt: skip
        return 2
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "gap_rows.jsonl"
    done = {}
    if path.exists():
        for line in path.read_text().splitlines():
            r = json.loads(line)
            done[(r["backend"], r["seed"], r["k"])] = r
    todo = [{"backend": b, "seed": a.seed_base + i, "k": k} for i in range(a.n) for k in ks
            for b in ("kernel", "foreign") if (b, a.seed_base + i, k) not in done]
    print(f"{len(done)} rows done, {len(todo)} to run", flush=True)
    with mp.get_context("spawn").Pool(a.jobs) as pool, open(path, "a") as fh:
        for i, r in enumerate(pool.imap_unordered(job, todo), start=1):
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            done[(r["backend"], r["seed"], r["k"])] = r
            print(f"[{i}/{len(todo)}] K={r['k']} {r['backend']} {r['seed']}: "
                  f"{r['segments']} segments, false alarm {r['false_alarm']}", flush=True)
    text = summary([r for r in done.values() if r["k"] in ks], ks)
    (out / "gap_summary.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
