"""False-alarm calibration of the mismatch tool on clean recordings.

    python experiments/mismatch_calibration.py [--n 60] [--jobs 2] [--out DIR]

Clean recordings (no concealed effect) from the generator with varied seeds, excitations,
noise levels, durations and sample rates.  For each, the tool's first greedy step gives
every candidate's Holm-adjusted p-value and the locate step its smallest adjusted p; a
false alarm at level alpha is ``min(p_holm) < alpha`` or ``locate p < alpha``.  Prints and
writes the false-alarm rate at several alpha (with a 95 % Clopper-Pearson interval), the
effect families that raise the alarms, and the chosen ``FAMILY_ALPHA`` / ``LOCATE_ALPHA``
check (tmopt/mismatch/calibration.py).
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import sys
from pathlib import Path

import numpy as np
from scipy import stats

SETTINGS = (
    {},
    {"excitation": "multisine:3e-5@240,3e-6@50;2e-5@400,1e-5@90"},
    {"excitation": "chirp:2e-5,0.001,0.008;2e-5,0.001,0.008"},
    {"excitation": "steps:2e-5,150;1e-5,200"},
    {"noise_scale": 0.5},
    {"noise_scale": 2.0},
    {"duration": 600.0},
    {"duration": 1800.0, "sample_rate": 5.0},
    {"sample_rate": 20.0, "duration": 900.0},
    {"controller": "pid"},
)
ALPHAS = (0.001, 0.005, 0.01, 0.02, 0.05)


def run(job: tuple[int, dict]) -> dict:
    from tmopt.mismatch.diagnose import Settings, diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.generate import generate_recording

    seed, st = job
    rec, _ = generate_recording([], seed=seed, **st)
    dg = diagnose(data_from_recording(rec), Settings(max_effects=1))
    evals = dg.steps[0]
    best = min(evals, key=lambda e: e.p_holm)
    return {"seed": seed, "settings": str(st), "min_p_holm": best.p_holm,
            "min_p_family": best.candidate.effect, "min_p_key": best.candidate.key,
            "locate_p": dg.locations.min_p, "detected_default": dg.mismatch_detected}  # fmt: skip


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    lo = stats.beta.ppf(0.025, k, n - k + 1) if k else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--n", type=int, default=60, help="number of clean recordings")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default="experiments/out/mismatch_calibration")
    p.add_argument("--realistic", action="store_true",
                   help="flight-like clean recordings of both simulators (issue 26; "
                        "calibration seeds 20000 onwards)")
    p.add_argument("--seed-base", type=int, default=20000,
                   help="with --realistic: first calibration seed (default 20000; the "
                        "benchmark's sets start at 40000)")
    p.add_argument("--joint", action="store_true",
                   help="with --realistic: the joint stage's statistics under the alternative's "
                        "noise and its per-family inflation (tmopt/mismatch/joint.py; resumable)")
    p.add_argument("--with-effects", action="store_true",
                   help="with --joint: recordings that hold one catalogue effect (SNR 20 and "
                        "60) or one out-of-catalogue effect, calibration seeds 21000 onwards; "
                        "an addition whose name is not the truth's is a wrong addition")
    args = p.parse_args(argv)
    if args.n < 1 or args.jobs < 1:
        print("error: --n and --jobs must be >= 1", file=sys.stderr)
        return 2
    if not 0 <= args.seed_base < 40000:
        print("error: --seed-base must be in [0, 40000) (40000 on are the benchmark's)",
              file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.joint and not args.realistic:
        print("error: --joint needs --realistic", file=sys.stderr)
        return 2
    if args.with_effects and not args.joint:
        print("error: --with-effects needs --joint", file=sys.stderr)
        return 2
    if args.joint:
        return _joint(args, out)
    if args.realistic:
        return _realistic(args, out)
    jobs = [(5000 + i, SETTINGS[i % len(SETTINGS)]) for i in range(args.n)]
    with mp.get_context("spawn").Pool(args.jobs) as pool:
        rows = []
        for i, r in enumerate(pool.imap(run, jobs), start=1):
            rows.append(r)
            print(f"[{i}/{len(jobs)}] {r['settings']}: min p_holm {r['min_p_holm']:.3g} "
                  f"({r['min_p_key']}), locate p {r['locate_p']:.3g}", flush=True)  # fmt: skip
    with open(out / "clean_runs.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    n = len(rows)
    lines = ["| alpha (catalogue = locate) | false alarms | rate | 95 % interval |",
             "|---|---|---|---|"]  # fmt: skip
    for a in ALPHAS:
        k = sum(r["min_p_holm"] < a or r["locate_p"] < a for r in rows)
        lo, hi = clopper_pearson(k, n)
        lines.append(f"| {a:g} | {k}/{n} | {k / n:.3f} | [{lo:.3f}, {hi:.3f}] |")
    k = sum(r["detected_default"] for r in rows)
    lines.append(f"\nWith the tool's defaults: {k}/{n} clean recordings flagged "
                 f"({k / n:.3f}, 95 % interval {clopper_pearson(k, n)}).")  # fmt: skip
    fam: dict[str, int] = {}
    for r in rows:
        if r["min_p_holm"] < 0.05:
            fam[r["min_p_family"]] = fam.get(r["min_p_family"], 0) + 1
    lines.append(f"Families with p_holm < 0.05 on clean data: {fam or 'none'}.")
    lines.append(f"Median min p_holm: {np.median([r['min_p_holm'] for r in rows]):.3g}; "
                 f"median locate p: {np.median([r['locate_p'] for r in rows]):.3g}.")  # fmt: skip
    text = "\n".join(lines) + "\n"
    (out / "summary.md").write_text(text)
    print(text)
    return 0


def _realistic(args, out: Path) -> int:
    """False alarms on clean flight-like recordings (n per simulator): per alpha of the
    first step, and under the tool's full defaults with what raised each (streamed to
    ``realistic_clean_rows.jsonl``, resumable)."""
    from mismatch_realistic import calibration_job, calibration_jobs, streamed_rows

    todo = [{"backend": b, "seed": s} for b, s in calibration_jobs(args.n, args.seed_base)]
    rows = streamed_rows(out / "realistic_clean_rows.jsonl", todo, calibration_job, args.jobs,
                         key=lambda r: (r["backend"], r["seed"]))  # fmt: skip
    want = {(j["backend"], j["seed"]) for j in todo}
    rows = [r for r in rows if (r["backend"], r["seed"]) in want]
    with open(out / "realistic_clean_runs.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=sorted({k for r in rows for k in r}))
        w.writeheader()
        w.writerows(rows)
    text = realistic_summary(rows)
    (out / "realistic_summary.md").write_text(text)
    print(text)
    return 0


def realistic_summary(rows: list[dict]) -> str:
    """Per simulator: first-step false alarms per alpha, the full defaults' rate with its
    95 % interval, and every alarm with what raised it."""
    lines = ["| backend | alpha (first step) | false alarms | 95 % interval | refused |",
             "|---|---|---|---|---|"]  # fmt: skip
    for b in ("kernel", "foreign"):
        sel = [r for r in rows if r["backend"] == b and not r["refused"]]
        refused = sum(bool(r["refused"]) for r in rows if r["backend"] == b)
        for a in ALPHAS:
            k = sum(r["min_p_holm"] < a or r["locate_p"] < a for r in sel)
            lo, hi = clopper_pearson(k, len(sel))
            lines.append(f"| {b} | {a:g} | {k}/{len(sel)} | [{lo:.3f}, {hi:.3f}] | {refused} |")
    lines += ["", "| backend | full defaults: false alarms | rate | 95 % interval |",
              "|---|---|---|---|"]  # fmt: skip
    for b in ("kernel", "foreign", "both"):
        sel = [r for r in rows if (b == "both" or r["backend"] == b) and not r["refused"]
               and r.get("false_alarm") is not None]  # fmt: skip
        k = sum(r["false_alarm"] for r in sel)
        lo, hi = clopper_pearson(k, len(sel))
        lines.append(f"| {b} | {k}/{len(sel)} | {k / max(len(sel), 1):.3f} | "
                     f"[{lo:.3f}, {hi:.3f}] |")  # fmt: skip
    lines += ["", "Alarms (full defaults):", ""]
    for r in rows:
        if r.get("false_alarm"):
            what = "; ".join(f"{x['what']}[{x['channel']}] GLR {x['glr'] or float('nan'):.1f} "
                             f"p_holm {x['p_holm'] or float('nan'):.2g}" for x in r["raised"])
            lines.append(f"- {r['backend']} {r['seed']}: {what or 'unexplained'} "
                         f"{r.get('unexplained_channels') or ''}")  # fmt: skip
    return "\n".join(lines) + "\n"


def joint_job(job: tuple[str, int] | dict) -> dict:
    """One realistic recording -- clean (``(backend, seed)``) or holding the effects of a
    benchmark-style case (a dict, :func:`mismatch_realistic.build`) --: the tool without
    its joint stage, then the joint stage's re-tests of what it left out
    (tmopt.mismatch.joint.alt_statistics), raw.  ``truth``: the catalogue names injected
    (none for clean and out-of-catalogue recordings)."""
    import time

    from mismatch_realistic import build

    from tmopt.mismatch import joint
    from tmopt.mismatch.diagnose import Settings, diagnose, evaluate
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.generate import GenerationError
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    case = job if isinstance(job, dict) else {"backend": job[0], "seed": job[1], "items": []}
    backend, seed = case["backend"], case["seed"]
    t0 = time.process_time()
    try:
        if case["items"]:
            sc, effects, ooc, _ = build(case)
        else:
            sc, effects, ooc = draw_scenario(seed, backend), [], []
        rec, _ = realistic_recording(sc, effects, ooc, seed, backend)
    except GenerationError as exc:  # a diverged loop: kept as a row, never scored
        return {"backend": backend, "seed": seed, "refused": f"generation: {exc}",
                "tests": [], "category": case.get("category", "clean"), "truth": [],
                "items": [i.get("name") for i in case["items"]]}  # fmt: skip
    settings = Settings(joint=False)
    dg = diagnose(data_from_recording(rec), settings)
    row = {"backend": backend, "seed": seed, "refused": dg.refused or "", "tests": [],
           "category": case.get("category", "clean"),
           "truth": sorted({e.name for e in effects}),
           "items": [i.get("name") for i in case["items"]]}  # fmt: skip
    if dg.refused:
        return row
    chosen = {ev.candidate.key for ev, _ in dg.selected}
    evals = evaluate(dg.data, dg.basis, dg.after, settings, chosen)
    tests = joint.alt_statistics(dg.data, dg.basis, dg.after, evals, settings,
                                 pairs=not dg.selected, screen=1.0)  # fmt: skip
    row.update(selected=sorted(chosen), detected=bool(dg.mismatch_detected),
               n_tests=len(dg.steps[0]),
               cpu_s=time.process_time() - t0,
               tests=[{"keys": t.keys, "family": t.family, "glr_null": t.glr_null,
                       "glr_alt": t.glr_alt, "dof": t.dof, "trials": t.trials,
                       "n_searched": t.n_searched, "n_obs": t.n_obs} for t in tests])
    return row


#: First seed of the effect-holding calibration recordings (20000-20199: the clean ones).
EFFECT_SEED_BASE = 21000


def effect_jobs(n: int) -> list[dict]:
    """``n`` rounds per simulator of: every catalogue effect at SNR 20 and 60 and every
    out-of-catalogue effect, at the benchmark's SNRs (experiments/mismatch_realistic.py)
    on calibration seeds from :data:`EFFECT_SEED_BASE` (never benchmark seeds)."""
    from mismatch_realistic import SNR_LEVELS, SNR_OOC

    from tmopt.mismatch.effects import EFFECT_NAMES
    from tmopt.mismatch.realistic import OUT_OF_CATALOGUE

    items = [[{"kind": "effect", "name": e, "snr": s}] for e in EFFECT_NAMES for s in SNR_LEVELS]
    items += [[{"kind": "ooc", "name": o, "snr": SNR_OOC}] for o in OUT_OF_CATALOGUE]
    jobs, seed = [], EFFECT_SEED_BASE
    for _ in range(n):
        for it in items:
            for b in ("kernel", "foreign"):
                cat = "catalogue" if it[0]["kind"] == "effect" else "out-of-catalogue"
                jobs.append({"backend": b, "seed": seed, "category": cat, "items": it})
            seed += 1
    return jobs


def screened_tests(row: dict, alpha: float) -> tuple[list[dict], int]:
    """A row's raw re-tests (the ``TOP`` strongest eligible, unscreened) reduced to what
    the stage tests at ``alpha`` (tmopt.mismatch.joint.screened / pair_indices), and how
    many of its pairs the raw row lacks (a screened candidate ranked below PAIR_TOP)."""
    from tmopt.mismatch.joint import pair_indices

    singles = [t for t in row["tests"] if len(t["keys"]) == 1]
    raw_pairs = dict(zip(pair_indices([t["keys"][0] for t in singles]),
                         [t for t in row["tests"] if len(t["keys"]) == 2]))  # fmt: skip
    n = row["n_tests"]  # significant for the selection itself: banned there, never re-tested
    keep = [i for i, t in enumerate(singles)
            if n * t["trials"] * stats.chi2.sf(t["glr_null"], t["dof"]) >= alpha
            > min(1.0, t["trials"] * stats.chi2.sf(t["glr_null"], t["dof"]))]  # fmt: skip
    out, missing = [singles[i] for i in keep], 0
    if row.get("selected") == []:
        for a, b in pair_indices([singles[i]["keys"][0] for i in keep]):
            t = raw_pairs.get((keep[a], keep[b]))
            if t is None:
                missing += 1
            else:
                out.append(t)
    return out, missing


def _key_name(key: str) -> str:
    return key.split("[", 1)[0]


def joint_alarms(rows: list[dict], inflation: dict, alpha: float,
                 wrong_only: bool = True) -> list[dict]:  # fmt: skip
    """Recordings on which the joint stage would add something at ``inflation`` and
    ``alpha`` (its first addition).  ``wrong``: a name the row's ``truth`` lacks -- any
    addition on a clean or out-of-catalogue recording, a second name beside a single
    catalogue effect; ``wrong_only``: only those."""
    from tmopt.mismatch.joint import JointTest, trials

    out = []
    for r in rows:
        raw, _ = screened_tests(r, alpha)
        tests = [JointTest(evals=[], **{k: t[k] for k in ("glr_null", "glr_alt", "dof", "trials",
                                                          "n_searched", "n_obs", "family")})
                 for t in raw]  # fmt: skip
        hits = [(t.score(trials(r["n_tests"], len(k["keys"])), inflation), k)
                for k, t in zip(raw, tests) if t.family in inflation]  # fmt: skip
        hits = [(t, k) for t, k in hits if t.significant(alpha)]
        if hits:
            t, k = max(hits, key=lambda h: h[0].dbic)
            wrong = any(_key_name(key) not in r.get("truth", []) for key in k["keys"])
            if wrong or not wrong_only:
                out.append({"backend": r["backend"], "seed": r["seed"], "keys": k["keys"],
                            "family": t.family, "p": t.p_value, "wrong": wrong,
                            "items": r.get("items", [])})  # fmt: skip
    return out


def _joint(args, out: Path) -> int:
    """The joint stage's null distribution per family and its false alarms (resumable)."""
    import json

    from mismatch_realistic import calibration_jobs

    path = out / ("joint_effect_rows.jsonl" if args.with_effects else "joint_rows.jsonl")
    rows = [json.loads(x) for x in path.open()] if path.exists() else []
    done = {(r["backend"], r["seed"]) for r in rows}
    jobs = effect_jobs(args.n) if args.with_effects else calibration_jobs(args.n)
    jobs = [j for j in jobs if _job_key(j) not in done]
    with mp.get_context("spawn").Pool(args.jobs) as pool, path.open("a") as fh:
        for i, r in enumerate(pool.imap(joint_job, jobs), start=1):
            rows.append(r)
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            best = max(r["tests"], key=lambda t: t["glr_alt"], default=None)
            print(f"[{i}/{len(jobs)}] {r['backend']} {r['seed']} {r.get('items', [])}: selected "
                  f"{r.get('selected')}, largest glr_alt "
                  f"{best and (best['keys'], round(best['glr_alt'], 1))}", flush=True)  # fmt: skip
    text = joint_effect_summary(rows) if args.with_effects else joint_summary(rows)
    name = "joint_effect_summary.md" if args.with_effects else "joint_summary.md"
    (out / name).write_text(text)
    print(text)
    return 0


def _job_key(job: tuple[str, int] | dict) -> tuple[str, int]:
    return (job["backend"], job["seed"]) if isinstance(job, dict) else tuple(job)


def joint_effect_summary(rows: list[dict]) -> str:
    """On recordings that hold one effect: the joint stage's additions at the tool's
    constants (right: a catalogue name the selection missed; wrong: any other), and per
    family the smallest inflation at which its wrong additions are at most ``alpha n / 2``
    (the clean calibration's rule, section 9.9, with wrong additions for false alarms)."""
    from tmopt.mismatch import calibration as cal
    from tmopt.mismatch.joint import INFLATION

    rows = [r for r in rows if not r["refused"]]
    n, alpha = len(rows), cal.FAMILY_ALPHA
    lines = [f"{n} recordings with one effect scored "
             f"({sum(r['category'] == 'catalogue' for r in rows)} catalogue, "
             f"{sum(r['category'] == 'out-of-catalogue' for r in rows)} out of catalogue; "
             f"{sum(r['backend'] == 'kernel' for r in rows)} kernel).", "",
             "| family | smallest inflation, wrong additions <= alpha n / 2 | wrong additions "
             "at the tool's constant | right additions at it |", "|---|---|---|---|"]  # fmt: skip
    for fam in ("drift", "other"):
        c = 1.0
        while len(joint_alarms(rows, {fam: c}, alpha)) > alpha * n / 2 and c < 100:
            c = round(c + 0.05, 2)
        at = joint_alarms(rows, {fam: INFLATION[fam]}, alpha, wrong_only=False)
        lines.append(f"| {fam} | {c:.2f} | {sum(a['wrong'] for a in at)} | "
                     f"{sum(not a['wrong'] for a in at)} |")  # fmt: skip
    at = joint_alarms(rows, INFLATION, alpha, wrong_only=False)
    lo, hi = clopper_pearson(sum(a["wrong"] for a in at), n)
    lines += ["", f"At INFLATION = {INFLATION}, alpha = {alpha:g}: "
              f"{sum(a['wrong'] for a in at)}/{n} wrong additions (95 % interval "
              f"[{lo:.3f}, {hi:.3f}]), {sum(not a['wrong'] for a in at)} right."]  # fmt: skip
    for a in at:
        lines.append(f"- {'WRONG' if a['wrong'] else 'right'}: {a['backend']} {a['seed']} "
                     f"{a['items']} + {a['keys']} ({a['family']}, p = {a['p']:.3g})")
    return "\n".join(lines) + "\n"


def joint_summary(rows: list[dict]) -> str:
    """Per family: the largest statistics and the smallest inflation at which the stage
    adds something on at most ``alpha / 2`` of the clean recordings (two families: the
    stage at most ``alpha``); the false alarms of the tool's constants
    (tmopt.mismatch.joint.INFLATION) at the tool's level."""
    from tmopt.mismatch import calibration as cal
    from tmopt.mismatch.joint import INFLATION

    rows = [r for r in rows if not r["refused"]]
    n = len(rows)
    lines = [f"{n} clean recordings scored ({sum(r['backend'] == 'kernel' for r in rows)} "
             f"kernel, {sum(r['backend'] == 'foreign' for r in rows)} foreign).", "",
             "| family | tests | largest glr_alt (keys) | median glr_alt / glr_null | "
             "smallest inflation, <= alpha n / 2 alarms |", "|---|---|---|---|---|"]  # fmt: skip
    alpha = cal.FAMILY_ALPHA
    screened = [screened_tests(r, alpha) for r in rows]
    for fam in ("drift", "other"):
        ts = [t for raw, _ in screened for t in raw if t["family"] == fam]
        if not ts:
            continue
        big = max(ts, key=lambda t: t["glr_alt"])
        ratio = np.median([t["glr_alt"] / max(t["glr_null"], 1e-9) for t in ts])
        c = 1.0  # each family at half the level: the stage's alarms at most alpha n
        while len(joint_alarms(rows, {fam: c}, alpha)) > alpha * n / 2 and c < 100:
            c = round(c + 0.05, 2)
        lines.append(f"| {fam} | {len(ts)} | {big['glr_alt']:.1f} ({big['keys']}) | "
                     f"{ratio:.2f} | {c:.2f} |")  # fmt: skip
    lines.append(f"\nRe-tested per recording (screened at alpha = {alpha:g}): "
                 f"{sum(len(raw) for raw, _ in screened)} tests on {n} recordings, "
                 f"{sum(bool(raw) for raw, _ in screened)} recordings with any; pairs the raw "
                 f"rows lack: {sum(m for _, m in screened)}.")  # fmt: skip
    lines.append("")
    lines.append("| backend | false alarms of the joint stage, INFLATION = "
                 f"{INFLATION}, alpha = {alpha:g} | 95 % interval |")
    lines.append("|---|---|---|")
    for b in ("kernel", "foreign", "both"):
        sel = [r for r in rows if b in (r["backend"], "both")]
        al = joint_alarms(sel, INFLATION, alpha)
        lo, hi = clopper_pearson(len(al), len(sel))
        lines.append(f"| {b} | {len(al)}/{len(sel)} | [{lo:.3f}, {hi:.3f}] |")
    for a in joint_alarms(rows, INFLATION, alpha):
        lines.append(f"- alarm: {a['backend']} {a['seed']} {a['keys']} ({a['family']}, "
                     f"p = {a['p']:.3g})")  # fmt: skip
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
