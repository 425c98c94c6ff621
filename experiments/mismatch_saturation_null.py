"""Null of the saturation check (docs/mismatch.md 9.10): the largest rail count
(:func:`tmopt.mismatch.plausibility.rail_mask`) of every measured channel on realistic
recordings of development seeds, per category, and how many recordings the check flags.
Generation only (no diagnosis): the check reads the data.

    python experiments/mismatch_saturation_null.py [--seed-base 20000] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv: list[str] | None = None) -> int:
    from mismatch_realistic import build, cases

    from tmopt.mismatch.fit import AXES, data_from_recording
    from tmopt.mismatch.plausibility import saturations
    from tmopt.mismatch.realistic import realistic_recording

    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--seed-base", type=int, default=20000)
    p.add_argument("--out", default="experiments/out/mismatch_saturation_null.jsonl")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w") as fh:
        for backend in ("kernel", "foreign"):
            for case in cases(backend, args.seed_base, False):
                truth = "+".join(i.get("name", "storm") for i in case["items"]) or "clean"
                try:
                    sc, effects, ooc, _ = build(case)
                    rec, _ = realistic_recording(sc, effects, ooc, case["seed"], backend)
                except Exception as exc:  # a diverged loop: not a recording
                    print(backend, case["seed"], "generation:", exc, flush=True)
                    continue
                d = data_from_recording(rec)
                ties = {}
                for kind, arr in (("acc_", d.acc), ("", d.x)):
                    for a, name in enumerate(AXES):
                        v = arr[a]
                        ties[kind + name] = int(max(np.sum(v == v.max()), np.sum(v == v.min())))
                row = {"backend": backend, "seed": case["seed"], "category": case["category"],
                       "truth": truth, "largest_extreme_count": max(ties.values()),
                       "flagged": [s["channel"] for s in saturations(d)]}  # fmt: skip
                fh.write(json.dumps(row) + "\n")
                fh.flush()
                print(json.dumps(row), flush=True)
    rows = [json.loads(s) for s in out.read_text().splitlines()]
    for clip in (False, True):
        sel = [r for r in rows if (r["truth"] == "acc_clipping") == clip]
        print(f"{'acc_clipping' if clip else 'every other recording'}: {len(sel)}, flagged "
              f"{sum(bool(r['flagged']) for r in sel)}, largest extreme count outside a "
              f"flag {max([r['largest_extreme_count'] for r in sel if not r['flagged']] or [0])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
