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
    args = p.parse_args(argv)
    if args.n < 1 or args.jobs < 1:
        print("error: --n and --jobs must be >= 1", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
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
    """False alarms on clean flight-like recordings (n per simulator), per alpha."""
    from mismatch_realistic import calibration_job, calibration_jobs

    with mp.get_context("spawn").Pool(args.jobs) as pool:
        rows = []
        for i, r in enumerate(pool.imap(calibration_job, calibration_jobs(args.n)), start=1):
            rows.append(r)
            print(f"[{i}/{2 * args.n}] {r['backend']} {r['seed']}: min p_holm "
                  f"{r['min_p_holm']:.3g} ({r['min_p_key']}), locate p {r['locate_p']:.3g}"
                  f"{' REFUSED ' + r['refused'] if r['refused'] else ''}", flush=True)  # fmt: skip
    with open(out / "realistic_clean_runs.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=sorted({k for r in rows for k in r}))
        w.writeheader()
        w.writerows(rows)
    lines = ["| backend | alpha | false alarms | 95 % interval | refused |",
             "|---|---|---|---|---|"]  # fmt: skip
    for b in ("kernel", "foreign"):
        sel = [r for r in rows if r["backend"] == b and not r["refused"]]
        refused = sum(bool(r["refused"]) for r in rows if r["backend"] == b)
        for a in ALPHAS:
            k = sum(r["min_p_holm"] < a or r["locate_p"] < a for r in sel)
            lo, hi = clopper_pearson(k, len(sel))
            lines.append(f"| {b} | {a:g} | {k}/{len(sel)} | [{lo:.3f}, {hi:.3f}] | {refused} |")
    text = "\n".join(lines) + "\n"
    (out / "realistic_summary.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
