"""What the tool's first selection step saw on benchmark recordings.

    python experiments/mismatch_first_step.py --records kernel:340140,foreign:340140 \
        [--match "x2 readout"] [--top 8] [--setting NAME=VALUE ...]

For each recording (made as ``mismatch_benchmark.py --realistic`` makes it), the
diagnosis with today's defaults (or ``--setting``), and from its first step the ``--top``
candidates by p-value and every candidate whose key contains ``--match``: key, GLR and
Holm-adjusted p.  Why: a miss with nothing reported says nothing about how near it came;
e.g. an x2 readout stamped late (340140, docs/mismatch.md 9.7's thirty-fourth run).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _row(e) -> str:
    return f"{e.candidate.key} GLR {e.glr:.1f} p_holm {e.p_holm:.3g}"


def main(argv: list[str] | None = None) -> None:
    from mismatch_realistic import case_recording, parse_records, parse_settings

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--records", required=True,
                    help="SEED (both simulators) or BACKEND:SEED, comma-separated")
    ap.add_argument("--match", default="", help="also list every candidate key containing this")
    ap.add_argument("--top", type=int, default=8)
    ap.add_argument("--setting", action="append", help="NAME=VALUE (a diagnose.Settings field)")
    a = ap.parse_args(argv)
    records = parse_records(a.records)
    try:
        settings = parse_settings(a.setting)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None
    if a.top < 1:
        raise SystemExit(f"--top: must be >= 1 (got {a.top})")

    from tmopt.mismatch.diagnose import Settings, diagnose
    from tmopt.mismatch.fit import data_from_recording

    for backend, seed in records:
        rec, _ = case_recording(backend, seed)
        dg = diagnose(data_from_recording(rec), Settings(**settings))
        step = dg.steps[0] if dg.steps else []
        print(f"{backend}:{seed} first step, {len(step)} candidates", flush=True)
        for e in sorted(step, key=lambda e: e.p_value)[:a.top]:
            print("    " + _row(e))
        for e in (e for e in step if a.match and a.match in e.candidate.key):
            print("    match: " + _row(e))


if __name__ == "__main__":
    main()
