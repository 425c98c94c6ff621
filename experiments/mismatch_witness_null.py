"""A witness-driven candidate's statistic under the alternative's noise model (rotation
coupling; docs/mismatch.md 9.28; :func:`tmopt.mismatch.diagnose._witness_alternative`).

    python experiments/mismatch_witness_null.py null --seed-base 37200 --n 60 \
        --out results/mismatch_witness_null/null.jsonl
    python experiments/mismatch_witness_null.py sizes results/mismatch_witness_null/null.jsonl
    python experiments/mismatch_witness_null.py summary results/mismatch_witness_null/null.jsonl
    python experiments/mismatch_witness_null.py diagnose --seed-base 37260 --n 20 \
        --out results/mismatch_witness_null/diagnose.jsonl
    python experiments/mismatch_witness_null.py case kernel:260057 foreign:250057 ...
    python experiments/mismatch_witness_null.py moving --rows RUN/realistic_rows.jsonl \
        --out results/mismatch_witness_null/moving.jsonl

* ``null`` -- clean flight-like recordings of both simulators (calibration seeds < 40000)
  whose attitude witnesses move with no coupling force (the null of the test: a column
  shaped like the witnesses, none of it in the data): per recording and per witness motion
  (:data:`MOTIONS`), the rotation candidate's statistic ``L`` under the null's noise model
  and ``L_alt`` under the alternative's, at the nominal fit (JSON lines, resumable);
* ``sizes`` -- the first step's catalogue size (its Holm multiplicity) of the recordings
  with the largest ``L_alt`` (``--top``), added to their rows;
* ``summary`` -- from those rows: the ratio ``L_alt / L``, the largest ``L_alt``, tail
  counts, and the smallest ``c`` at which no ``L_alt / c`` reaches the selection's level
  (:func:`level`) at 150 candidates and at each sized recording's own catalogue -- the
  latter the rule of ``calibration.WITNESS_REFIT_INFLATION``;
* ``diagnose`` -- the whole tool on such recordings (one motion each, in turn): a false
  alarm is any mismatch said;
* ``case`` -- a benchmark recording (``backend:seed``): its rotation candidate's two
  statistics at the nominal fit;
* ``moving`` -- benchmark recordings of a finished run (``--rows``) that hold no
  rotation, diagnosed again with their witnesses moving (one motion each, in turn; no
  coupling added): what the tool says beside what the run's row says -- would a
  simulator whose attitude always moves make the rotation a wrong name?

Rates are arbitrary (1e-9 rad/s peak): the statistics do not depend on a column's scale.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))

from mismatch_realistic import (  # noqa: E402
    add_null_parser,
    clean_recording,
    null_args_error,
    per_recording,
    rows_done,
)

#: The selection's level for a 2-parameter candidate: chi^2_2 at FAMILY_ALPHA over the
#: catalogue's size (~150 candidates a step).
CATALOGUE_SIZE = 150
#: Witness motions of the null: slews about z (in-plane Euler term on the y axes) and
#: about x (out of plane: centrifugal terms only), slow attitude jitter about z and about
#: all three axes (the realistic generator's two profiles).
MOTIONS = ("slew_z", "slew_x", "jitter_z", "jitter_xyz")
PEAK = 1e-9


def level(n_tests: int = CATALOGUE_SIZE) -> float:
    from tmopt.mismatch import calibration as cal

    return float(stats.chi2.isf(cal.FAMILY_ALPHA / n_tests, 2))


def motion(time: np.ndarray, kind: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Witness rate and angular acceleration (3, N) of ``kind`` at ``time`` [s]: a slew
    with onset and length drawn from ``seed`` (onset in the first 60 % of the record,
    length 10-60 % of it), or the generator's slow jitter."""
    from tmopt.mismatch.effects.rotation_coupling import _jitter, _slew

    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5E11]))
    t = np.where(np.isfinite(time), time, 0.0)
    span = float(np.nanmax(time) - np.nanmin(time))
    w, wd = np.zeros((3, t.size)), np.zeros((3, t.size))
    if kind.startswith("slew"):
        t0 = float(np.nanmin(time)) + rng.uniform(0.0, 0.6) * span
        t1 = min(t0 + rng.uniform(0.1, 0.6) * span, float(np.nanmax(time)))
        j = "xyz".index(kind[-1])
        w[j], wd[j] = _slew(t, t0, t1, PEAK * rng.choice((-1.0, 1.0)))
    else:
        for j in (range(3) if kind == "jitter_xyz" else (2,)):
            w[j], wd[j] = _jitter(t, PEAK, seed, j)
    bad = ~np.isfinite(time)
    w[:, bad], wd[:, bad] = np.nan, np.nan
    return w, wd


def nominal(rec):
    """``(data, basis, state)``: ``rec`` prepared and its nominal fit, as the tool starts."""
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare
    from tmopt.mismatch.fit import data_from_recording

    d, basis = prepare(data_from_recording(rec))
    return d, basis, fit_state(d, basis, [], [], False, Settings())


def rotation_statistics(d, basis, state) -> tuple[float, float] | None:
    """``(L, L_alt)`` of the rotation candidate against ``state`` (None: no witnesses)."""
    from tmopt.mismatch.diagnose import residual_groups
    from tmopt.mismatch.effects import Context
    from tmopt.mismatch.effects.rotation_coupling import RotationCoupling
    from tmopt.mismatch.joint import alt_glr

    ctx = Context(d, basis, state.eq_fit.residual, state.eq_noise)
    cands = RotationCoupling().candidates(ctx)
    if not cands:
        return None
    cols = cands[0].columns
    return residual_groups(d, state)["equation"].glr(cols), alt_glr(d, basis, state, cols)[0]


def statistics_of(rec, seed: int) -> list[tuple[str, float, float]]:
    """``(motion, L, L_alt)`` of the rotation candidate at the nominal fit of ``rec``
    with each of :data:`MOTIONS` in its witnesses."""
    d, basis, state = nominal(rec)
    out = []
    for kind in MOTIONS:
        d.omega, d.omega_dot = motion(d.time, kind, seed)
        out.append((kind, *rotation_statistics(d, basis, state)))
    return out


def with_witnesses(rec, kind: str, seed: int):
    """``rec`` with its attitude witnesses moving as ``kind`` (no coupling force)."""
    from tmopt.physics.recording import Recording, validate

    w, wd = motion(np.asarray(rec["time"], float), kind, seed)
    chans = dict(rec.channels)
    for j, c in enumerate("xyz"):
        chans[f"sc_omega_{c}"], chans[f"sc_omega_dot_{c}"] = w[j], wd[j]
    return validate(Recording(chans, dict(rec.attrs), source=rec.source))


def null(seed_base: int, n: int, out: Path) -> None:
    per_recording(seed_base, n, out,
                  lambda b, seed, i: {"rows": statistics_of(clean_recording(seed, b), seed)})


def summary(paths: list[str]) -> None:
    rows = [json.loads(x) for p in paths for x in open(p)]
    flat = [(r["backend"], r["seed"], *x) for r in rows for x in r["rows"]]
    lam = np.array([x[3] for x in flat])
    alt = np.array([x[4] for x in flat])
    print(f"{len(rows)} recordings, {len(flat)} witness motions ({', '.join(MOTIONS)})")
    ok = lam > 1.0
    if ok.any():
        r = alt[ok] / lam[ok]
        print(f"L_alt / L where L > 1: median {np.median(r):.3f}, 90 % {np.quantile(r, 0.9):.3f}, "
              f"max {r.max():.3f}")  # fmt: skip
    for kind in MOTIONS:
        sel = np.array([x[2] == kind for x in flat])
        print(f"  {kind}: L median {np.median(lam[sel]):.2f} max {lam[sel].max():.2f}; "
              f"L_alt median {np.median(alt[sel]):.2f} max {alt[sel].max():.2f}")  # fmt: skip
    order = np.argsort(-alt)[:5]
    print("largest L_alt: " + "; ".join(f"{flat[i][0]} {flat[i][1]} {flat[i][2]} "
                                         f"L {lam[i]:.2f} L_alt {alt[i]:.2f}" for i in order))
    cs = (1.0, 1.5, 2.0, 3.0)
    print(f"tail counts above chi^2_2's point at q (expected n q; L alone; max(L, L_alt/c) "
          f"for c in {cs}):")  # fmt: skip
    for q in (0.05, 0.01, 0.001):
        thr = stats.chi2.isf(q, 2)
        counts = [int(np.sum(np.maximum(lam, alt / c) > thr)) for c in cs]
        print(f"  q {q}: expected {len(flat) * q:.1f}, L {int(np.sum(lam > thr))}, {counts}")
    lev = level()
    need = float(alt.max() / lev) if alt.size else 1.0
    print(f"selection level {lev:.2f}: the smallest c at which no candidate reaches it: "
          f"{max(need, 1.0):.3f}")  # fmt: skip
    sized = {(r["backend"], r["seed"]): r["n_tests"] for r in rows if "n_tests" in r}
    if sized:  # the level at each recording's own first-step catalogue (``sizes``)
        own = [x[4] / level(sized.get((x[0], x[1]), CATALOGUE_SIZE)) for x in flat]
        i = int(np.argmax(own))
        print(f"at each recording's own catalogue size ({len(sized)} recordings sized, the "
              f"rest at {CATALOGUE_SIZE}): the smallest c at which none reaches it: "
              f"{max(own[i], 1.0):.3f} ({flat[i][0]} {flat[i][1]} {flat[i][2]}, "
              f"{sized.get((flat[i][0], flat[i][1]), CATALOGUE_SIZE)} candidates)")  # fmt: skip


def sizes(paths: list[str], top: int) -> None:
    """Adds ``n_tests`` -- the first step's catalogue size, the multiplicity its Holm
    correction uses -- to the rows of the ``top`` recordings with the largest ``L_alt``
    (their levels are the ones that decide the factor), rewriting each file."""
    from tmopt.mismatch.diagnose import Settings, evaluate

    tables = {p: [json.loads(x) for x in open(p)] for p in paths}
    rows = sorted((r for t in tables.values() for r in t),
                  key=lambda r: -max(x[2] for x in r["rows"]))  # fmt: skip
    for r in rows[:top]:
        if "n_tests" in r:
            continue
        kind = max(r["rows"], key=lambda x: x[2])[0]
        d, basis, state = nominal(with_witnesses(clean_recording(r["seed"], r["backend"]), kind,
                                                 r["seed"]))  # fmt: skip
        r["n_tests"] = len(evaluate(d, basis, state, Settings(), set()))
        print(f"{r['backend']} {r['seed']} ({kind}): {r['n_tests']} candidates", flush=True)
    for p, t in tables.items():
        Path(p).write_text("".join(json.dumps(r) + "\n" for r in t))


def diagnose_rows(seed_base: int, n: int, out: Path) -> None:
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.report import build_report

    def job(b: str, seed: int, i: int) -> dict:
        kind = MOTIONS[i % len(MOTIONS)]
        rep = build_report(diagnose(data_from_recording(
            with_witnesses(clean_recording(seed, b), kind, seed))))  # fmt: skip
        return {"motion": kind, "alarm": bool(rep["mismatch_detected"]),
                "names": [f"{e['name']}[{e['channel']}]" for e in rep["effects"]],
                "unexplained": (rep.get("unexplained_at") or {}).get("channels", [])}

    per_recording(seed_base, n, out, job)
    rows = [json.loads(x) for x in out.open()]
    alarms = [r for r in rows if r["alarm"]]
    rot = [r for r in rows if any(x.startswith("rotation") for x in r["names"])]
    print(f"{len(rows)} clean recordings with moving witnesses: {len(alarms)} alarms, "
          f"{len(rot)} naming a rotation coupling")  # fmt: skip


def case(specs: list[str]) -> None:
    from mismatch_realistic import case_recording

    for spec in specs:
        b, seed = spec.split(":")
        got = rotation_statistics(*nominal(case_recording(b, int(seed))[0]))
        print(f"{spec}: " + ("no attitude witnesses" if got is None else
                             f"L {got[0]:.2f} L_alt {got[1]:.2f}"))  # fmt: skip


def moving(rows_path: str, categories: list[str], out: Path) -> None:
    from mismatch_realistic import case_recording, score

    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.report import build_report

    rows = [json.loads(x) for x in open(rows_path)]
    rows = [r for r in rows if r["category"] in categories and "rotation" not in r["truth"]
            and "found" in r]  # fmt: skip
    out.parent.mkdir(parents=True, exist_ok=True)
    done = rows_done(out)
    with out.open("a") as fh:
        for i, r in enumerate(rows):
            if (r["backend"], r["seed"]) in done:
                continue
            rec, truth = case_recording(r["backend"], r["seed"])
            kind = MOTIONS[i % len(MOTIONS)]
            rep = build_report(diagnose(data_from_recording(
                with_witnesses(rec, kind, r["seed"]))))  # fmt: skip
            new = score(rep, truth)
            row = {"backend": r["backend"], "seed": r["seed"], "category": r["category"],
                   "truth": r["truth"], "motion": kind, "found_still": r["found"],
                   "found_moving": new["found"],
                   "unexplained_still": r["unexplained_channels"],
                   "unexplained_moving": new["unexplained_channels"],
                   "wrong_still": r["wrong"], "wrong_moving": new["wrong"]}  # fmt: skip
            fh.write(json.dumps(row) + "\n")
            fh.flush()
            print(json.dumps(row), flush=True)
    rows = [json.loads(x) for x in out.open()]
    same = [r for r in rows if r["found_still"] == r["found_moving"]
            and r["unexplained_still"] == r["unexplained_moving"]]  # fmt: skip
    rot = [r for r in rows if "rotation" in r["found_moving"]]
    print(f"{len(rows)} recordings with moving witnesses: {len(same)} say what they said; "
          f"{len(rot)} name a rotation coupling; wrong names {sum(r['wrong_moving'] for r in rows)}"
          f" (still: {sum(r['wrong_still'] for r in rows)})")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("null", "diagnose"):
        add_null_parser(sub, name, 37200 if name == "null" else 37260,
                        60 if name == "null" else 20, f"results/mismatch_witness_null/{name}.jsonl")
    sub.add_parser("summary").add_argument("paths", nargs="+")
    p = sub.add_parser("sizes")
    p.add_argument("paths", nargs="+")
    p.add_argument("--top", type=int, default=10)
    sub.add_parser("case").add_argument("recordings", nargs="+")
    p = sub.add_parser("moving")
    p.add_argument("--rows", required=True, help="a finished run's realistic_rows.jsonl")
    p.add_argument("--categories", default="out-of-catalogue,pair",
                   help="comma-separated benchmark categories (default: %(default)s)")
    p.add_argument("--out", default="results/mismatch_witness_null/moving.jsonl")
    a = ap.parse_args(argv)
    if a.cmd in ("null", "diagnose"):
        if error := null_args_error(a):
            print(error, file=sys.stderr)
            return 2
        (null if a.cmd == "null" else diagnose_rows)(a.seed_base, a.n, Path(a.out))
    elif a.cmd == "summary":
        summary(a.paths)
    elif a.cmd == "sizes":
        sizes(a.paths, a.top)
    elif a.cmd == "case":
        case(a.recordings)
    else:
        moving(a.rows, a.categories.split(","), Path(a.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
