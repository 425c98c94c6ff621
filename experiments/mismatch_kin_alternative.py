"""The kinematic group's statistic under the alternative's noise model (docs/mismatch.md
9.24; :func:`tmopt.mismatch.diagnose._kin_alternative_group`) and by its profile
likelihood ratio (9.29; :func:`tmopt.mismatch.diagnose._kin_profile`).

    python experiments/mismatch_kin_alternative.py null --seed-base 37060 --n 60 \
        --out results/mismatch_kin_alternative/null.jsonl
    python experiments/mismatch_kin_alternative.py summary \
        results/mismatch_kin_alternative/null.jsonl
    python experiments/mismatch_kin_alternative.py case kernel:220066 foreign:220064 ...
    python experiments/mismatch_kin_alternative.py redraw foreign:280020 \
        --key "sensing_cross_talk[disp:x1<-x2]" --noise-seeds 38300-38307
    python experiments/mismatch_kin_alternative.py cost kernel:220000 foreign:220001
    python experiments/mismatch_kin_alternative.py cost --option kin_profile kernel:220000

* ``null`` -- clean flight-like recordings of both simulators (calibration seeds < 40000),
  the nominal fit: every kinematic candidate's statistic ``L`` under the null's noise model,
  ``L_alt`` under the alternative's and its profile ratio ``L_prof`` (computed for every
  testable candidate, past the selection's screen; one row per recording, JSON lines,
  resumable);
* ``summary`` -- from those rows: the ratio ``L_alt / L``, the largest ``L_alt``, the tail
  counts of ``max(L, L_alt / c)`` above chi^2's points against the null's own, and the
  ``c`` at which no candidate reaches the selection's level (:data:`LEVEL`) -- the rule of
  ``calibration.KIN_REFIT_INFLATION``; and ``L_prof``'s mean, tail counts and largest;
* ``case`` -- a benchmark recording (``backend:seed``): its three kinematic candidates
  with the largest ``L_alt``, both statistics;
* ``redraw`` -- a clean recording's scenario (``backend:seed``) recorded again with other
  noise draws (``--noise-seeds``): one kinematic candidate's (``--key``) estimate, its
  standard error and ``L`` per draw, and their mean -- a simulator's own small residual
  is the same in every draw, the null's tail is not;
* ``cost`` -- a whole diagnosis with and without an option (``--option``: ``kin_refit``,
  the default, or ``kin_profile``), alternated three times in one process: the median
  ratio.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: The selection's level for one candidate: chi^2_1 at FAMILY_ALPHA over the catalogue's
#: size (~150 candidates a step).
CATALOGUE_SIZE = 150


def _level() -> float:
    from tmopt.mismatch import calibration as cal

    return float(stats.chi2.isf(cal.FAMILY_ALPHA / CATALOGUE_SIZE, 1))


def statistics_of(rec) -> list[tuple[str, int, float, float | None, float | None]]:
    """``(key, dof, L, L_alt, L_prof)`` of every kinematic candidate of the recording's
    nominal fit (``L_prof`` None for a candidate without an instrument)."""
    from tmopt.mismatch.diagnose import (
        Settings,
        _kin_candidates,
        _kin_groups,
        fit_state,
        prepare,
        residual_groups,
    )
    from tmopt.mismatch.fit import data_from_recording

    d, basis = prepare(data_from_recording(rec))
    st = Settings(kin_refit=True, kin_profile=True)
    s = fit_state(d, basis, [], [], False, st)
    cands = _kin_candidates(d, basis, s, st)
    g = residual_groups(d, s)["kinematic"]
    shared = _kin_groups(d, s, cands, st)  # one fit with every kinematic column: both
    alt, profile = shared["kinematic_alt"], shared["kinematic_profile"]

    def prof(c):  # an infinite L passes the screen: the ratio itself
        testable = all(col.instrument is None or np.any(col.instrument) for col in c.columns)
        return profile(c.columns, float("inf")) if testable else None

    return [(c.key, len(c.columns), g.glr(c.columns), alt.glr(c.columns) if alt else None,
             prof(c)) for c in cands]  # fmt: skip


def null(seed_base: int, n: int, out: Path) -> None:
    from mismatch_realistic import clean_recording, per_recording

    def shown(row: dict) -> str:
        top = max((r[3] or 0.0) for r in row["rows"]) if row["rows"] else 0.0
        return f"{row['backend']} {row['seed']}: {len(row['rows'])} candidates, largest " \
            f"L_alt {top:.2f}"  # fmt: skip

    per_recording(seed_base, n, out,
                  lambda b, seed, i: {"rows": statistics_of(clean_recording(seed, b))}, shown)


def summary(paths: list[str]) -> None:
    rows = [json.loads(x) for p in paths for x in open(p)]
    c_rows = [(r["backend"], r["seed"], *x) for r in rows for x in r["rows"] if x[3] is not None]
    dof = np.array([x[3] for x in c_rows])
    lam = np.array([x[4] for x in c_rows])
    alt = np.array([x[5] for x in c_rows])
    print(f"{len(rows)} recordings, {len(c_rows)} kinematic candidates")
    ok = lam > 1.0
    r = alt[ok] / lam[ok]
    print(f"L_alt / L where L > 1: median {np.median(r):.3f}, 90 % {np.quantile(r, 0.9):.3f}, "
          f"99 % {np.quantile(r, 0.99):.3f}, max {r.max():.3f}")  # fmt: skip
    order = np.argsort(-alt)[:5]
    print("largest L_alt: " + "; ".join(f"{c_rows[i][0]} {c_rows[i][1]} {c_rows[i][2]} "
                                         f"L {lam[i]:.2f} L_alt {alt[i]:.2f}" for i in order))
    cs = (1.0, 2.0, 4.0, 7.25)
    print("tail counts above chi^2_dof's point at q (expected n q; L alone; max(L, L_alt/c) "
          f"for c in {cs}):")  # fmt: skip
    for q in (0.01, 0.003, 0.001):
        thr = stats.chi2.isf(q, dof)
        counts = [int(np.sum(np.maximum(lam, alt / c) > thr)) for c in cs]
        print(f"  q {q}: expected {len(c_rows) * q:.1f}, L {int(np.sum(lam > thr))}, {counts}")
    level = _level()
    need = float(alt.max() / level) if alt.size else 1.0
    print(f"selection level {level:.2f}: the smallest c at which no candidate reaches it: "
          f"{max(need, 1.0):.3f}")  # fmt: skip
    _profile_summary([x for x in c_rows if len(x) > 6 and x[6] is not None], level)


def _profile_summary(rows: list, level: float) -> None:
    """``L_prof`` (rows written since stop 53): mean per dof, tail counts, the largest."""
    if not rows:
        return
    dof = np.array([x[3] for x in rows])
    prof = np.array([x[6] for x in rows])
    print(f"profile ratio, {len(rows)} candidates: mean / dof {np.mean(prof / dof):.3f}")
    for q in (0.05, 0.01, 0.001):
        print(f"  q {q}: expected {len(rows) * q:.1f}, L_prof "
              f"{int(np.sum(prof > stats.chi2.isf(q, dof)))}")  # fmt: skip
    order = np.argsort(-prof)[:3]
    print("largest L_prof: " + "; ".join(f"{rows[i][0]} {rows[i][1]} {rows[i][2]} "
                                         f"L {rows[i][4]:.2f} L_alt {rows[i][5] or 0:.2f} "
                                         f"L_prof {prof[i]:.2f}" for i in order)
          + f" (the selection's level {level:.2f})")  # fmt: skip


def case(specs: list[str]) -> None:
    from mismatch_realistic import case_recording

    for spec in specs:
        b, seed = spec.split(":")
        rec, _ = case_recording(b, int(seed))
        rows = sorted(statistics_of(rec), key=lambda x: -(x[3] or 0.0))[:3]
        print(spec + ": " + "; ".join(f"{k} L {lam:.2f} L_alt {a or 0:.2f} L_prof {p or 0:.2f}"
                                      for k, _, lam, a, p in rows))  # fmt: skip


def redraw(spec: str, key: str, noise_seeds: list[int]) -> None:
    from tmopt.mismatch.diagnose import (
        Settings,
        _kin_candidates,
        fit_state,
        prepare,
        residual_groups,
    )
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    b, seed = spec.split(":")
    sc = draw_scenario(int(seed), b)
    est = []
    for noise_seed in [int(seed), *noise_seeds]:
        rec, _ = realistic_recording(sc, (), (), noise_seed, b)
        d, basis = prepare(data_from_recording(rec))
        s = fit_state(d, basis, [], [], False, Settings())
        group = residual_groups(d, s)["kinematic"]
        cands = [c for c in _kin_candidates(d, basis, s, Settings()) if c.key == key]
        if not cands:
            raise SystemExit(f"error: --key {key!r} is not a kinematic candidate of {spec}")
        value, sigma = group.estimate(cands[0].columns[0])
        est.append((value, sigma))
        print(f"{b} scenario {seed}, noise {noise_seed}: {key} {value:.3g} +- {sigma:.2g}, "
              f"L {group.glr(cands[0].columns):.2f}", flush=True)  # fmt: skip
    v, sd = np.array(est[1:]).T  # the other draws: the recording itself was picked
    if v.size:
        w = 1 / sd**2
        mean, se = float(np.sum(w * v) / np.sum(w)), float(np.sum(w) ** -0.5)
        print(f"the {v.size} other draws: weighted mean {mean:.3g} +- {se:.2g} "
              f"({mean / se:.1f} sigma)")  # fmt: skip


def _seeds(text: str) -> list[int]:
    """``A-B`` or comma-separated seeds."""
    if "-" in text:
        lo, hi = map(int, text.split("-"))
        return list(range(lo, hi + 1))
    return [int(x) for x in text.split(",") if x]


def cost(specs: list[str], option: str = "kin_refit") -> None:
    from mismatch_realistic import case_recording

    from tmopt.mismatch.diagnose import Settings, diagnose
    from tmopt.mismatch.fit import data_from_recording

    for spec in specs:
        b, seed = spec.split(":")
        rec, _ = case_recording(b, int(seed))
        ratios = []
        for _ in range(3):
            t = {}
            for on in (False, True):
                t0 = time.perf_counter()
                diagnose(data_from_recording(rec), Settings(**{option: on}))
                t[on] = time.perf_counter() - t0
            ratios.append(t[True] / t[False])
        print(f"{spec}: diagnosis with / without {option} {statistics.median(ratios):.2f}x "
              f"({', '.join(f'{x:.2f}' for x in ratios)})")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    from mismatch_realistic import add_null_parser, null_args_error

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    add_null_parser(sub, "null", 37060, 60, "results/mismatch_kin_alternative/null.jsonl")
    sub.add_parser("summary").add_argument("paths", nargs="+")
    sub.add_parser("case").add_argument("recordings", nargs="+")
    p = sub.add_parser("redraw")
    p.add_argument("recording")
    p.add_argument("--key", required=True)
    p.add_argument("--noise-seeds", type=_seeds, default=list(range(38300, 38308)))
    p = sub.add_parser("cost")
    p.add_argument("--option", choices=("kin_refit", "kin_profile", "onset_profile"),
                   default="kin_refit")
    p.add_argument("recordings", nargs="+")
    a = ap.parse_args(argv)
    if a.cmd == "null":
        if error := null_args_error(a):
            print(error, file=sys.stderr)
            return 2
        null(a.seed_base, a.n, Path(a.out))
    elif a.cmd == "summary":
        summary(a.paths)
    elif a.cmd == "case":
        case(a.recordings)
    elif a.cmd == "redraw":
        redraw(a.recording, a.key, a.noise_seeds)
    else:
        cost(a.recordings, a.option)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
