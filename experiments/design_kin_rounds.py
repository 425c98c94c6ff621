"""Where a kinematic (IV) effect's realised standard error leaves its prediction: the
diagnosis' noise iteration.

Usage: python experiments/design_kin_rounds.py LOOP_JSON [LOOP_JSON ...] [--min-ratio 1.3]

For each row of ``experiments/design_next_loop.py``'s ``loop.json`` whose realised
standard error is more than ``--min-ratio`` x (or less than 1/that) the prediction at the
second recording's own noise estimate (``se_predicted_noise2``: the information model's
error alone), the second recording is made again (same injection, excitation, duration and
seed) and diagnosed, and the selected model's kinematic group is fitted again with
:func:`tmopt.mismatch.diagnose._fit_kin` for exactly 2 (the diagnosis' own before it
iterated to the fixed point, ``KIN_SETTLE``), 3 and 6 rounds of "fit, then re-estimate
the noise model from its residual". The row's effect SE of each is printed beside the
prediction: when the 2-round SE is far from the converged one, a 2-round fit is whitened
by a noise model that had not converged. On loops made with the settled fit no row is
outside ``--min-ratio`` (docs/design.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tmopt.mismatch.diagnose import _fit_kin, diagnose
from tmopt.mismatch.fit import data_from_recording, kinematic_target
from tmopt.mismatch.generate import generate_recording

sys.path.insert(0, str(Path(__file__).resolve().parent))
from design_next_loop import CASES  # noqa: E402  (the loop's effects: one home)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("loop_json", nargs="+")
    ap.add_argument("--min-ratio", type=float, default=1.3)
    args = ap.parse_args(argv)
    rows = [r for f in args.loop_json for r in json.loads(Path(f).read_text())]
    print("| effect | seed | predicted SE at rec. 2's noise | reported SE (2 rounds) | "
          "3 rounds | 6 rounds |\n|---|---|---|---|---|---|")
    for r in rows:
        pred, real = r.get("se_predicted_noise2"), r.get("se_realised")
        if not pred or not real or 1 / args.min_ratio <= real / pred <= args.min_ratio:
            continue
        inj = CASES[r["effect"]][0]
        rec, _ = generate_recording([inj], seed=r["seed"] + 1000, excitation=r["excitation"],
                                    duration=r["duration"])  # fmt: skip
        dg = diagnose(data_from_recording(rec))
        st, d = dg.after, dg.data
        name = next(c.name for c in st.kin_cols if c.name.startswith(r["effect"]))
        se = []
        for rounds in (2, 3, 6):
            fit, _ = _fit_kin(kinematic_target(d), st.kin_cols, d.kin_layout, d.fs, rounds)
            se.append(fit.sigma(name))
        print(f"| {r['effect']} | {r['seed']} | {pred:.3g} | {se[0]:.3g} | {se[1]:.3g} | "
              f"{se[2]:.3g} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
