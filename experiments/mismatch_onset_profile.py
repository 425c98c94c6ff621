"""A generic force step or relaxation -- or, with ``--feature line``, a force line -- read
by its profile likelihood ratio (docs/mismatch.md 9.30, 9.40;
:func:`tmopt.mismatch.diagnose._equation_profile`, ``Settings.onset_profile``,
``Settings.line_profile``).

    python experiments/mismatch_onset_profile.py null --seed-base 37370 --n 30 \
        --out results/mismatch_onset_profile/null.jsonl
    python experiments/mismatch_onset_profile.py summary results/mismatch_onset_profile/null.jsonl
    python experiments/mismatch_onset_profile.py case kernel:280112 foreign:270118
    python experiments/mismatch_onset_profile.py cost kernel:280112 foreign:280012
    python experiments/mismatch_onset_profile.py --feature line null --seed-base 37480 --n 20

* ``null`` -- clean flight-like recordings of both simulators (calibration seeds < 40000),
  the nominal fit: every onset feature's candidate (a step and a relaxation per axis, each
  at the onset its search placed) with its GLR ``L`` under the null's noise model, its
  profile ratio ``L_prof``, its trials factor and both p-values (one row per recording,
  JSON lines, resumable);
* ``summary`` -- from those rows: how often ``L_prof`` exceeds ``L`` and by how much, and
  the candidates whose p-value (trials included) reaches the first step of the
  selection's Holm ladder (``FAMILY_ALPHA`` over :data:`CATALOGUE_SIZE`), under ``L``
  and under ``L_prof``: the false alarms the option could add;
* ``case`` -- a benchmark recording (``backend:seed``): its onset candidates, both
  statistics and p-values;
* ``cost`` -- a whole diagnosis with and without the option, alternated three times in
  one process: the median ratio (``mismatch_kin_alternative.cost``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: The selection's Holm ladder starts at FAMILY_ALPHA over about this many candidates.
CATALOGUE_SIZE = 150


#: ``--feature``: the generic features read, and the option that reads them.
FEATURES = {"onset": "onset_profile", "line": "line_profile"}
#: The null's default rows (resumable, keyed by recording: another feature's rows go to
#: ``null_<feature>.jsonl`` beside it, never into this file).
NULL_OUT = "results/mismatch_onset_profile/null.jsonl"


def onset_statistics(rec, feature: str = "onset") -> list[dict]:
    """Every onset feature's (``feature`` "line": line feature's) candidate of the
    recording's nominal fit: ``feature``, ``channel``, ``t0_s`` (a line's
    ``frequency_hz``), ``L``, ``L_prof``, ``trials``, ``p`` and ``p_prof``."""
    from tmopt.mismatch import generic
    from tmopt.mismatch.diagnose import (
        Settings,
        _equation_alternatives,
        _generic_feature,
        fit_state,
        prepare,
        residual_groups,
    )
    from tmopt.mismatch.effects import Context
    from tmopt.mismatch.fit import data_from_recording

    d, basis = prepare(data_from_recording(rec))
    st = Settings(**{FEATURES[feature]: True})
    s = fit_state(d, basis, [], [], False, st)
    ctx = Context(d, basis, s.eq_fit.residual, s.eq_noise)
    group = residual_groups(d, s)["equation"]
    profile = _equation_alternatives(d, basis, s, st)["equation_profile"]
    out = []
    read = profile.features
    for c in generic.candidates(ctx, st.timing_regressor, st.line_refine):
        if _generic_feature(c) not in read:
            continue
        lam = group.glr(c.columns)
        prof = profile(c.columns, float("inf"))  # past the screen: the ratio itself
        dof = len(c.columns)
        out.append({"feature": c.fixed["feature"], "channel": c.channel,
                    "t0_s": c.fixed.get("t0_s", c.fixed.get("frequency_hz")), "L": lam,
                    "L_prof": prof,
                    "trials": c.trials,
                    "p": min(1.0, c.trials * float(stats.chi2.sf(lam, dof))),
                    "p_prof": min(1.0, c.trials * float(stats.chi2.sf(prof, dof)))})  # fmt: skip
    return out


def null(seed_base: int, n: int, out: Path, feature: str = "onset") -> None:
    from mismatch_realistic import clean_recording, per_recording

    per_recording(seed_base, n, out, lambda b, seed, i: {
        "rows": onset_statistics(clean_recording(seed, b), feature)}, _shown)


def _shown(row: dict) -> str:
    top = max(row["rows"], key=lambda r: r["L_prof"]) if row["rows"] else None
    return f"{row['backend']} {row['seed']}: {len(row['rows'])} candidates" + (
        f", largest L_prof {top['L_prof']:.1f} ({top['feature']} {top['channel']}, "
        f"L {top['L']:.1f})" if top else "")  # fmt: skip


def summary(paths: list[str]) -> None:
    from tmopt.mismatch import calibration as cal

    recs = [json.loads(x) for p in paths for x in open(p)]
    rows = [(r["backend"], r["seed"], c) for r in recs for c in r["rows"]]
    lam = np.array([c["L"] for *_, c in rows])
    prof = np.array([c["L_prof"] for *_, c in rows])
    print(f"{len(recs)} clean recordings, {len(rows)} candidates")
    if not rows:
        return
    d = prof - lam
    print(f"L_prof - L: median {np.median(d):.2f}, 90 % {np.quantile(d, 0.9):.2f}, "
          f"max {d.max():.2f}; L_prof > L in {int(np.sum(d > 0))}")  # fmt: skip
    level = cal.FAMILY_ALPHA / CATALOGUE_SIZE
    for key in ("p", "p_prof"):
        ps = np.array([c[key] for *_, c in rows])
        hit = [f"{b} {s} {c['feature']}[{c['channel']}] L {c['L']:.1f} L_prof "
               f"{c['L_prof']:.1f} p {c[key]:.2g}" for b, s, c in rows if c[key] < level]
        print(f"{key}: below 0.05 {int(np.sum(ps < 0.05))}, below 0.5 {int(np.sum(ps < 0.5))};"
              f" at the Holm ladder's first step ({level:.1e}): {len(hit)}"
              + ("".join(f"\n  {h}" for h in hit)))  # fmt: skip
    order = np.argsort(-prof)[:5]
    print("largest L_prof: " + "; ".join(
        f"{rows[i][0]} {rows[i][1]} {rows[i][2]['feature']}[{rows[i][2]['channel']}] "
        f"L {lam[i]:.1f} L_prof {prof[i]:.1f}" for i in order))  # fmt: skip


def case(specs: list[str], feature: str = "onset") -> None:
    from mismatch_realistic import case_recording

    for spec in specs:
        b, seed = spec.split(":")
        rec, _ = case_recording(b, int(seed))
        for c in sorted(onset_statistics(rec, feature), key=lambda c: c["p_prof"]):
            print(f"{spec} {c['feature']}[{c['channel']}] at {c['t0_s']:.6g}: L {c['L']:.1f} "
                  f"(p {c['p']:.2g}), L_prof {c['L_prof']:.1f} (p {c['p_prof']:.2g}), "
                  f"trials {c['trials']:.0f}")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    from mismatch_realistic import add_null_parser, null_args_error

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--feature", choices=sorted(FEATURES), default="onset")
    sub = ap.add_subparsers(dest="cmd", required=True)
    add_null_parser(sub, "null", 37370, 30, NULL_OUT)
    sub.add_parser("summary").add_argument("paths", nargs="+")
    sub.add_parser("case").add_argument("recordings", nargs="+")
    sub.add_parser("cost").add_argument("recordings", nargs="+")
    a = ap.parse_args(argv)
    if a.cmd == "null":
        if error := null_args_error(a):
            print(error, file=sys.stderr)
            return 2
        out = Path(a.out)
        if a.feature != "onset" and a.out == NULL_OUT:  # a resumable file per feature
            out = out.with_name(f"null_{a.feature}.jsonl")
        null(a.seed_base, a.n, out, a.feature)
    elif a.cmd == "summary":
        summary(a.paths)
    elif a.cmd == "case":
        case(a.recordings, a.feature)
    else:
        from mismatch_kin_alternative import cost

        cost(a.recordings, FEATURES[a.feature])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
