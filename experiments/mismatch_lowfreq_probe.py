"""Probe of the low-frequency shape statistics under the 1/f^2 acceleration noise (issue 26,
job `lowfreq`; docs/mismatch.md 9.11).

    python experiments/mismatch_lowfreq_probe.py --clean 21000:21030 [--out DIR] [--summarise]
    python experiments/mismatch_lowfreq_probe.py --cases kernel:50000,kernel:50118 --seed-base 50000

Per recording, in the equation group only (the group the drift, the curvature and the
shape check live in), for every axis a:

* ``curv0``: the curvature feature's GLR (``generic._curvatures``' column) against the
  nominal fit, the noise estimated under the null (what the selection tests);
* ``shape0``: the drift's shape check (``BiasDrift.shape_check``: Legendre P2, P3) with a
  linear drift on a fitted, noise under that model (what ``diagnose.shape_misfits`` tests);
* ``shape1``: the same GLR with the noise re-estimated with P2, P3 fitted too (the
  alternative's noise, as the joint stage, 9.9);
* ``drift0``: the drift column's GLR against the nominal fit (null noise);
* ``timing0``: the readout timing feature's GLR (kinematic group, excited axes only);
* ``timing1``: the same with the band regressor (``Settings.timing_regressor`` ``"band"``:
  the accelerometer term's derivative below the excitation's band, not its tone part);
* ``timing0p``, ``timing1p``: the same two read as the selection reads a kinematic
  candidate by default (``Settings.kin_profile``: the profile likelihood ratio, screened
  by the shared alternative; ``diagnose._kin_groups``).

``--timing-only``: only the timing statistics (the null of the timing regressors without
the equation group's fits).  ``--backends``: the simulators of ``--clean``
(default both; one per process to use two cores).

``--clean``: clean flight-like recordings (calibration seeds) of both simulators: the null.
``--cases``: benchmark recordings (``backend:seed`` of the realistic set at ``--seed-base``):
the same statistics plus the tool's own diagnosis (selected keys, misfits).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _stats(data, basis, timing_only: bool = False) -> dict:
    from tmopt.mismatch.diagnose import _fit_eq, _Group
    from tmopt.mismatch.effects.base import Context
    from tmopt.mismatch.effects.bias_drift import BiasDrift
    from tmopt.mismatch.fit import (
        AXES,
        Column,
        axis_column,
        equation_target,
        nominal_equation_columns,
    )

    if timing_only:
        return _all_timing_stats(data, basis)
    target = equation_target(data, basis)
    nom = nominal_equation_columns(data, basis)
    fit0, noise0 = _fit_eq(target, nom, False, data.layout, data.fs, "smoothed")
    g0 = _Group(target, nom, fit0, noise0.whiten)
    t = data.time - data.time[0]
    span = max(float(np.ptp(data.time)), data.dt)
    curv = (data.centred_time / span) ** 2
    ctx = Context(data, basis, fit0.residual, noise0)
    out = {"curv0": [], "drift0": [], "shape0": [], "shape1": []}
    for a, ax in enumerate(AXES):
        ccol = Column(f"curv[{ax}]", axis_column(basis, a, curv))
        dcol = Column(f"bias_drift[{ax}]", axis_column(basis, a, t))
        out["curv0"].append(g0.glr([ccol]))
        out["drift0"].append(g0.glr([dcol]))
        cand = BiasDrift().candidates(ctx)[a]
        shape = BiasDrift().shape_check(ctx, cand)
        fit_d, noise_d = _fit_eq(target, nom + [dcol], False, data.layout, data.fs, "smoothed")
        out["shape0"].append(_Group(target, nom + [dcol], fit_d, noise_d.whiten).glr(shape))
        fit_s, noise_s = _fit_eq(target, nom + [dcol] + shape, False, data.layout, data.fs,
                                 "smoothed")  # fmt: skip
        out["shape1"].append(_Group(target, nom + [dcol], fit_d, noise_s.whiten).glr(shape))
    out.update(_all_timing_stats(data, basis))
    return out


def _all_timing_stats(data, basis) -> dict:
    """``timing0``/``timing1`` (GLR) and ``timing0p``/``timing1p`` (as the selection reads
    them) for the tone and the band regressor."""
    from tmopt.mismatch.diagnose import Settings, fit_state

    # the nominal fit does not depend on the timing regressor: one for both
    state = fit_state(data, basis, [], [], False, Settings())
    out = {}
    for i, reg in enumerate(("tones", "band")):
        out[f"timing{i}"], out[f"timing{i}p"] = _timing_stats(data, basis, state, reg)
    return out


def _timing_stats(data, basis, state, regressor: str) -> tuple[list[float], list[float]]:
    """The readout timing feature's GLR per axis (``generic._readout_timings`` with
    ``regressor``; NaN on an axis without excitation tones) in the kinematic group against
    the nominal fit, and the statistic the selection's first step reads it by (the profile
    ratio, ``Settings.kin_profile``, as ``diagnose._statistic`` reads it); ``state``: the
    nominal fit (``diagnose.fit_state``)."""
    from tmopt.mismatch import generic
    from tmopt.mismatch.diagnose import Settings, _kin_candidates, _kin_groups, residual_groups
    from tmopt.mismatch.effects.base import Context
    from tmopt.mismatch.fit import AXES

    settings = Settings(timing_regressor=regressor)
    group = residual_groups(data, state)["kinematic"]
    profile = _kin_groups(data, state, _kin_candidates(data, basis, state, settings),
                          settings)["kinematic_profile"]  # fmt: skip
    ctx = Context(data, basis, state.eq_fit.residual, state.eq_noise)
    glr, read = [math.nan] * len(AXES), [math.nan] * len(AXES)
    for cand in generic._readout_timings(ctx, regressor):
        a = AXES.index(cand.channel.split()[0])
        glr[a] = group.glr(cand.columns)
        read[a] = profile(cand.columns, glr[a]) if profile is not None else glr[a]
    return glr, read


def clean_row(backend: str, seed: int, timing_only: bool = False) -> dict:
    from tmopt.mismatch.diagnose import prepare
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    t0 = time.process_time()
    sc = draw_scenario(seed, backend)
    rec, _ = realistic_recording(sc, (), (), seed, backend)
    data, basis = prepare(data_from_recording(rec))
    row = {"set": "clean", "backend": backend, "seed": seed,
           **_stats(data, basis, timing_only)}  # fmt: skip
    row["cpu_s"] = time.process_time() - t0
    return row


def case_row(backend: str, seed: int, seed_base: int) -> dict:
    from mismatch_realistic import cases, diagnosed_case

    case = next(c for c in cases(backend, seed_base, False) if c["seed"] == seed)
    t0 = time.process_time()
    dg, snrs, error = diagnosed_case(case)
    row = {"set": "case", "backend": backend, "seed": seed, "category": case["category"],
           "truth": [i.get("name", i["kind"]) for i in case["items"]]}  # fmt: skip
    if error or dg.refused:
        return {**row, "error": error or dg.refused}
    row["selected"] = [ev.candidate.key for ev, _ in dg.selected]
    row["misfits"] = dg.misfits
    row.update(_stats(dg.data, dg.basis))
    row["cpu_s"] = time.process_time() - t0
    return row


#: The statistics calibrated: name in calibration.LOWFREQ_NULL, probe key, chi^2 dof.
CALIBRATED = (("ramp", "drift0", 1), ("curvature", "curv0", 1), ("shape", "shape0", 2),
              ("timing", "timing0", 1), ("timing", "timing1", 1),
              ("timing", "timing0p", 1), ("timing", "timing1p", 1))


def fit_null(values: np.ndarray, dof: int) -> tuple[float, float]:
    """``(scale, nu)`` of ``values ~ dof * scale * F(dof, nu)`` by maximum likelihood (nu
    in 1..1e4 on a log grid, scale profiled by a bounded 1-d search)."""
    from scipy import optimize, stats

    v = np.maximum(np.asarray(values, float) / dof, 1e-12)
    best = (-np.inf, 1.0, 1e4)
    for nu in np.geomspace(1.0, 1e4, 81):
        res = optimize.minimize_scalar(
            lambda ls, nu=nu: -float(np.sum(stats.f.logpdf(v / math.exp(ls), dof, nu))
                                     - v.size * ls),
            bounds=(-3.0, 3.0), method="bounded")  # fmt: skip
        if -res.fun > best[0]:
            best = (-res.fun, math.exp(res.x), float(nu))
    return round(best[1], 3), round(best[2], 1)


def _values(rows: list[dict], key: str, backend: str) -> np.ndarray:
    """Pooled per-axis values of one statistic (rows without it -- an older probe -- and
    NaN, an axis it does not apply to, left out)."""
    v = np.array([x for r in rows if key in r and backend in ("both", r["backend"])
                  for x in r[key]], float)  # fmt: skip
    return v[np.isfinite(v)]


def summarise(rows: list[dict]) -> str:
    from scipy import stats

    from tmopt.mismatch.calibration import LOWFREQ_NULL

    lines = [f"{len(rows)} clean recordings ({sum(r['backend'] == 'kernel' for r in rows)} "
             "kernel), per-axis values (4 per recording)",
             "| statistic | simulator | median (chi2) | 90 % (chi2) | max | share > chi2 99 % |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for key, dof in (("curv0", 1), ("drift0", 1), ("shape0", 2), ("shape1", 2), ("timing0", 1),
                     ("timing1", 1), ("timing0p", 1), ("timing1p", 1)):
        for b in ("kernel", "foreign", "both"):
            v = _values(rows, key, b)
            if not v.size:
                continue
            lines.append(f"| {key} | {b} | {np.median(v):.2f} ({stats.chi2.ppf(.5, dof):.2f}) | "
                         f"{np.quantile(v, .9):.1f} ({stats.chi2.ppf(.9, dof):.1f}) | "
                         f"{v.max():.1f} | {np.mean(v > stats.chi2.isf(.01, dof)):.3f} |")
    for name, key, dof in CALIBRATED:
        v = _values(rows, key, "both")
        if not v.size:
            continue
        scale, nu = fit_null(v, dof)
        fit = dof * scale * stats.f.isf(np.array([0.5, 0.1, 0.01, 1e-4]), dof, nu)
        shipped = LOWFREQ_NULL[name]
        beyond = np.mean(v > dof * shipped[0] * stats.f.isf(0.01, dof, shipped[1]))
        lines.append(f"{key}: fit ({scale}, {nu}) [shipped LOWFREQ_NULL[{name!r}] = {shipped}, "
                     f"values above its 99 %: {beyond:.3f}]: the fit's median / 90 % / 99 % / "
                     f"1 - 1e-4 quantiles {', '.join(f'{q:.1f}' for q in fit)} (chi2: "
                     + ", ".join(f"{q:.1f}" for q in stats.chi2.isf([0.5, 0.1, 0.01, 1e-4], dof))
                     + f"); values above its 99 %: {np.mean(v > fit[2]):.3f}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clean", default=None, help="seed range LO:HI of clean recordings")
    ap.add_argument("--cases", default=None, help="backend:seed,... of the realistic set")
    ap.add_argument("--seed-base", type=int, default=50000)
    ap.add_argument("--out", default="experiments/out/mismatch_lowfreq_probe")
    ap.add_argument("--timing-only", action="store_true",
                    help="only the readout timing statistics (timing0, timing1 and their "
                         "profile readings)")
    ap.add_argument("--backends", default="kernel,foreign",
                    help="the simulators of --clean, comma-separated")
    ap.add_argument("--summarise", action="store_true",
                    help="print the null's quantiles and the calibrated inflations")
    a = ap.parse_args(argv)
    backends = a.backends.split(",")
    if not backends or not set(backends) <= {"kernel", "foreign"}:
        raise SystemExit(f"--backends: kernel and/or foreign, comma-separated (got {a.backends!r})")
    path = Path(a.out) / "rows.jsonl"
    if a.summarise:
        rows = [r for r in map(json.loads, path.open()) if r["set"] == "clean"]
        if a.clean:
            lo, hi = (int(v) for v in a.clean.split(":"))
            rows = [r for r in rows if lo <= r["seed"] < hi]
        print(summarise(rows))
        return 0
    path.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if path.exists():
        done = {(r["set"], r["backend"], r["seed"]) for r in map(json.loads, path.open())}
    todo = []
    if a.clean:
        lo, hi = (int(v) for v in a.clean.split(":"))
        todo += [("clean", b, s) for s in range(lo, hi) for b in backends]
    if a.cases:
        for item in a.cases.split(","):
            b, s = item.split(":")
            todo.append(("case", b, int(s)))
    with path.open("a") as fh:
        for kind, b, s in todo:
            if (kind, b, s) in done:
                continue
            row = clean_row(b, s, a.timing_only) if kind == "clean" else \
                case_row(b, s, a.seed_base)  # fmt: skip
            fh.write(json.dumps(row, default=float) + "\n")
            fh.flush()
            print(json.dumps(row, default=float), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
