"""Benchmark of the mismatch tool on generated recordings with concealed effects.

    python experiments/mismatch_benchmark.py [--quick] [--jobs 2] [--out DIR]
    python experiments/mismatch_benchmark.py --realistic [--backend kernel|foreign|both]
        [--quick] [--seed-base 40000] [--jobs 2] [--out DIR] [--summarise]
        [--paired-with EARLIER_OUT] [--summarise [--rescore] [--distinct]]

``--realistic`` (issue 26): flight-like recordings from :mod:`tmopt.mismatch.realistic`
-- coloured noise in every channel, gaps, LPF glitch shapes, random durations (1200-3600 s),
rates (2-10 Hz), stiffness (+-2e-6 s^-2) and excitations within Eq. 20 -- made by the
project's kernel and by the independent simulator :mod:`tmopt.mismatch.foreign`.  Per
backend: ~20 % clean recordings, every catalogue effect at two signal-to-noise ratios
(20 and 60, in the recording's own noise), pairs (40 each), every out-of-catalogue effect
(:data:`tmopt.mismatch.realistic.OUT_OF_CATALOGUE`) and glitch storms.  Seeds start at
``--seed-base`` (40000: never used while developing or calibrating the tool -- those
used 0-99 and 20000-20199).  Scores: false alarms (clean), attribution with no extra
name (identifiable catalogue effects), "unexplained at the right channel" with no name
(out of catalogue), wrong names, refusals, tracebacks.  Writes ``realistic.csv``,
``realistic.md`` and every report and truth under ``--out``.

Recordings (``tmopt.mismatch.generate.generate_recording``): every catalogue effect at the
generator's calibrated "near" (SNR ~5, near the detection limit) and "large" (SNR ~50)
magnitudes, clean controls, and two-effect combinations; plus a generalisation set made
with settings the tool was not developed on (other excitations, noise levels, durations,
sample rates).  The truth is read here, by the scorer only, never by the tool.

Scores per recording: detected, top attribution correct (name; name and channel), truth
flagged as not identifiable/ambiguous, parameter recovery error, fit improvement (residual
RMS, BIC, whiteness) and the stiffness error before/after.  Writes ``results.csv`` and
``summary.md`` under ``--out`` and prints the summary table.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing as mp
import sys
import time
from pathlib import Path

import numpy as np

from tmopt.mismatch.effects import EFFECT_NAMES  # every catalogue effect, in its order

PAIRS = (
    ("actuation_gain", "bias_drift"), ("cubic_stiffness", "glitch"),
    ("actuation_delay", "stiffness_drift"), ("geometry_error", "readout_scale"),
    ("rotation_coupling", "actuation_gain"), ("sensing_cross_talk", "colored_noise"),
)  # fmt: skip
UNSEEN_EFFECTS = (("actuation_gain", "cubic_stiffness"), ("bias_drift", "glitch"))
# settings never used while developing the tool (the paper's defaults were)
UNSEEN = (
    {"excitation": "multisine:4e-5@250,5e-6@60;2e-5@350,4e-6@80"},
    {"excitation": "chirp:2e-5,0.001,0.008;1e-5,0.002,0.01"},
    {"noise_scale": 3.0},
    {"noise_scale": 0.3},
    {"duration": 2400.0},
    {"duration": 600.0, "sample_rate": 20.0},
    {"sample_rate": 5.0},
)


def cases(quick: bool) -> list[dict]:
    out = []
    seed = 1000
    for name in EFFECT_NAMES:
        for level in ("near", "large"):
            out.append({"set": f"single-{level}", "effects": [(name, level)], "settings": {},
                        "seed": (seed := seed + 1)})  # fmt: skip
    for _ in range(4 if quick else 8):
        out.append({"set": "clean", "effects": [], "settings": {}, "seed": (seed := seed + 1)})
    for a, b in PAIRS:
        out.append({"set": "pair-large", "effects": [(a, "large"), (b, "large")],
                    "settings": {}, "seed": (seed := seed + 1)})  # fmt: skip
    for k, st in enumerate(UNSEEN):
        out.append({"set": "unseen-clean", "effects": [], "settings": st,
                    "seed": (seed := seed + 1)})  # fmt: skip
        for name in UNSEEN_EFFECTS[k % 2]:
            out.append({"set": "unseen-large", "effects": [(name, "large")], "settings": st,
                        "seed": (seed := seed + 1)})  # fmt: skip
    if quick:
        keep = {"actuation_gain", "bias_drift", "glitch"}
        out = [c for c in out if not c["effects"] or {e for e, _ in c["effects"]} <= keep]
    return out


def run_case(case: dict) -> dict:
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.generate import calibrated_injection, generate_recording
    from tmopt.mismatch.report import build_report

    t0 = time.process_time()
    effects = [calibrated_injection(n, lv) for n, lv in case["effects"]]
    try:
        rec, truth = generate_recording(effects, seed=case["seed"], **case["settings"])
    except Exception as exc:  # a diverged loop is reported, not hidden
        return {**_ids(case), "error": f"generation: {exc}"}
    rep = build_report(diagnose(data_from_recording(rec)))
    row = {**_ids(case), **score(rep, truth), "cpu_s": time.process_time() - t0}
    if case.get("keep"):
        name = f"{case['set']}_{case['seed']}"
        Path(case["keep"], f"{name}.report.json").write_text(json.dumps(rep, default=float))
        Path(case["keep"], f"{name}.truth.json").write_text(json.dumps(truth, default=str))
    return row


def _ids(case: dict) -> dict:
    return {"set": case["set"], "seed": case["seed"],
            "truth": "+".join(f"{n}:{lv}" for n, lv in case["effects"]) or "clean",
            "settings": json.dumps(case["settings"])}  # fmt: skip


def _param_error(found: dict, truth: dict) -> float | None:
    """Relative error of the effect's main parameter, matched by name between the truth's
    parameters and the report's (the lever arm |r12| for rotation); None if not comparable.
    Magnitudes are compared: sign conventions may differ between generator and tool."""
    par = found["parameters"]
    pairs = [(truth.get("parameter"), truth.get("magnitude"))]
    pairs += [(k, v) for k, v in truth.get("parameters", {}).items() if not k.endswith("_s")]
    if "r12_s" in truth.get("parameters", {}) and "r12_x" in par:
        pairs.insert(0, ("r12_x", truth["parameters"]["r12_s"][0]))
    for name, val in pairs:
        est = par.get(name)
        if isinstance(est, (int, float)) and isinstance(val, (int, float)) and val:
            return abs(abs(est) - abs(val)) / abs(val)
    return None


def score(rep: dict, truth: dict) -> dict:
    teff = truth["effects"]
    names = [e["name"] for e in rep["effects"]]
    flagged = {(r["name"], r["channel"]) for r in rep["not_identifiable"]}
    ambiguous = {(a["name"], a["channel"]) for e in rep["effects"]
                 for a in e["evidence"]["alternatives"]}  # fmt: skip
    row = {"detected": rep["mismatch_detected"], "unexplained": rep["unexplained"],
           "found": ";".join(f"{e['name']}[{e['channel']}]" for e in rep["effects"])}  # fmt: skip
    correct = [t["name"] in names for t in teff]
    chan = [any(e["name"] == t["name"] and e["channel"] == t.get("tool_channel")
                for e in rep["effects"]) for t in teff]  # fmt: skip
    row["n_true"] = len(teff)
    row["attributed"] = sum(correct)
    row["attributed_channel"] = sum(chan)
    row["top_correct"] = bool(teff) and bool(names) and names[0] in {t["name"] for t in teff}
    row["flagged_or_ambiguous"] = sum((t["name"], t.get("tool_channel")) in flagged | ambiguous
                                      for t in teff)  # fmt: skip
    row["extra_effects"] = sum(n not in {t["name"] for t in teff} for n in names)
    errs = [_param_error(next(e for e in rep["effects"] if e["name"] == t["name"]), t)
            for t, ok in zip(teff, correct) if ok]  # fmt: skip
    errs = [e for e in errs if e is not None]
    row["param_rel_error"] = float(np.median(errs)) if errs else None
    fb, fa = rep["fit"]["before"], rep["fit"]["after"]
    row.update(rms_before=fb["residual_rms"], rms_after=fa["residual_rms"],
               bic_drop=fb["bic"] - fa["bic"], white_before=fb["whiteness_p"],
               white_after=fa["whiteness_p"])  # fmt: skip
    k = truth.get("stiffness", truth.get("settings", {}).get("stiffness", [1e-7] * 4))[0]
    row["k1_err_before"] = abs(rep["stiffness"]["before"]["k1xx"] - k)
    row["k1_err_after"] = abs(rep["stiffness"]["after"]["k1xx"] - k)
    return row


def _rate(rows, key, cond=lambda r: True) -> str:
    sel = [r for r in rows if cond(r) and "error" not in r]
    if not sel:
        return "—"
    return f"{sum(bool(r[key]) for r in sel)}/{len(sel)}"


def summarise(rows: list[dict]) -> str:
    lines = ["| set | recordings | detected | top attribution | all true effects named | "
             "truth flagged (aliased/ambiguous) | extra effects | median param error | "
             "median RMS after/before | median k1xx err after/before |",
             "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for s in sorted({r["set"] for r in rows}):
        sel = [r for r in rows if r["set"] == s and "error" not in r]
        if not sel:
            continue
        perr = [r["param_rel_error"] for r in sel if r.get("param_rel_error") is not None]
        rr = [r["rms_after"] / r["rms_before"] for r in sel]
        kk = [r["k1_err_after"] / max(r["k1_err_before"], 1e-30) for r in sel]
        eff = [r for r in sel if r["n_true"]]
        lines.append(
            f"| {s} | {len(sel)} | {_rate(sel, 'detected')} | "
            f"{_rate(eff, 'top_correct') if eff else '—'} | "
            f"{sum(r['attributed'] == r['n_true'] for r in eff)}/{len(eff)} | "
            f"{sum(r['flagged_or_ambiguous'] for r in eff)}/{sum(r['n_true'] for r in eff)} | "
            f"{sum(r['extra_effects'] for r in sel)} | "
            f"{np.median(perr):.3g} | {np.median(rr):.3f} | {np.median(kk):.3g} |"
            if perr else
            f"| {s} | {len(sel)} | {_rate(sel, 'detected')} | "
            f"{_rate(eff, 'top_correct') if eff else '—'} | "
            f"{sum(r['attributed'] == r['n_true'] for r in eff)}/{len(eff)} | "
            f"{sum(r['flagged_or_ambiguous'] for r in eff)}/{max(sum(r['n_true'] for r in eff), 0)}"
            f" | {sum(r['extra_effects'] for r in sel)} | — | {np.median(rr):.3f} | "
            f"{np.median(kk):.3g} |")  # fmt: skip
    return "\n".join(lines)


def per_effect(rows: list[dict]) -> str:
    lines = ["| effect | near: detected / named (found) | large: detected / named (found) |",
             "|---|---|---|"]  # fmt: skip
    for name in EFFECT_NAMES:
        cells = []
        for lv in ("near", "large"):
            r = next((r for r in rows if r["truth"] == f"{name}:{lv}" and r["set"].startswith(
                "single")), None)  # fmt: skip
            if r is None or "error" in r:
                cells.append("error" if r else "—")
            else:
                cells.append(f"{'yes' if r['detected'] else 'no'} / "
                             f"{'yes' if r['attributed'] else 'no'} ({r['found'] or '-'})")
        lines.append(f"| {name} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--quick", action="store_true", help="a small subset (smoke test)")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default="experiments/out/mismatch_benchmark")
    p.add_argument("--realistic", action="store_true",
                   help="flight-like recordings from both simulators (issue 26)")
    p.add_argument("--backend", choices=("kernel", "foreign", "both"), default="both")
    p.add_argument("--summarise", action="store_true",
                   help="with --realistic: score the rows already in --out, simulate nothing")
    p.add_argument("--rescore", action="store_true",
                   help="with --realistic --summarise: score the kept reports and truths "
                        "with today's scorer (the rows file is left as it is)")
    p.add_argument("--distinct", action="store_true",
                   help="with --realistic --summarise: for a run made before the scorer "
                        "had it, compute the physical limit -- how much of each injected "
                        "item no look-alike can stand in for (streamed to "
                        "realistic_ooc_distinct.jsonl, resumable; --jobs workers) -- then "
                        "score with it (second rates)")
    p.add_argument("--paired-with", default=None, metavar="DIR",
                   help="with --realistic: also score only the recordings that DIR (an "
                        "earlier run's --out) scored too, both runs side by side")
    p.add_argument("--only", default=None, metavar="SEEDS",
                   help="with --realistic: run only these recordings, comma-separated SEED "
                        "(both simulators) or BACKEND:SEED, e.g. 40036,foreign:40101")
    p.add_argument("--scaler-version", type=int, default=None, choices=(1, 2),
                   help="with --realistic: the SNR scaler's version (default: the current, 2; "
                        "1 remakes the sets read before stop 39; a run keeps its own)")
    p.add_argument("--setting", action="append", default=None, metavar="NAME=VALUE",
                   help="with --realistic: diagnose with this tool setting (a field of "
                        "tmopt.mismatch.diagnose.Settings, e.g. kin_profile=true; "
                        "repeatable); kept with the run, and a resume must ask the same")
    p.add_argument("--seed-base", type=int, default=40000,
                   help="first seed of the realistic set (default 40000: fresh seeds)")
    args = p.parse_args(argv)
    if args.jobs < 1:
        print("error: --jobs must be >= 1", file=sys.stderr)
        return 2
    if args.seed_base < 0:
        print("error: --seed-base must be >= 0", file=sys.stderr)
        return 2
    if args.distinct and not (args.realistic and args.summarise):
        print("error: --distinct needs --realistic --summarise (it scores a finished run)",
              file=sys.stderr)
        return 2
    if args.realistic and args.only:
        from mismatch_realistic import parse_only

        try:
            parse_only(args.only)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
    if args.setting and not args.realistic:
        print("error: --setting needs --realistic", file=sys.stderr)
        return 2
    if args.realistic:
        from mismatch_realistic import main_realistic, parse_settings

        try:
            args.settings = parse_settings(args.setting)
        except ValueError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        return main_realistic(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    todo = cases(args.quick)
    (out / "reports").mkdir(exist_ok=True)
    for c in todo:  # reports and truths kept for re-scoring and inspection
        c["keep"] = str(out / "reports")
    rows = []
    with mp.get_context("spawn").Pool(args.jobs) as pool:
        for i, row in enumerate(pool.imap(run_case, todo), start=1):
            rows.append(row)
            print(f"[{i}/{len(todo)}] {row['set']} {row['truth']} -> "
                  f"{row.get('found', row.get('error'))}", flush=True)  # fmt: skip
    keys = sorted({k for r in rows for k in r})
    with open(out / "results.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    text = "## By set\n\n" + summarise(rows) + "\n\n## By effect\n\n" + per_effect(rows) + "\n"
    (out / "summary.md").write_text(text)
    print(text)
    cpu = [r["cpu_s"] for r in rows if "cpu_s" in r]
    print(f"{len(rows)} recordings; CPU per recording: median {np.median(cpu):.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
