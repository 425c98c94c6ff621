"""Realistic recordings for the mismatch tool's benchmark and calibration (issue 26).

Used by ``python experiments/mismatch_benchmark.py --realistic`` (scores on fresh seeds)
and ``python experiments/mismatch_calibration.py --realistic`` (false alarms on clean
recordings, calibration seeds).  Recordings: :func:`tmopt.mismatch.realistic.draw_scenario`
per seed, effects scaled to a signal-to-noise ratio in that scenario's own noise
(:func:`tmopt.mismatch.realistic.scale_to_snr`), then simulated with the scenario's gaps by
the ``kernel`` (the project's simulator) or the ``foreign`` (independent) backend.  The
truth is read by the scorer only.

Seed ranges (disjoint, so nothing is tuned on the benchmark's own recordings):
development 0-99 (used while building the tool), calibration 20000-22199, benchmark
40000 onwards.
"""

from __future__ import annotations

import csv
import json
import math
import multiprocessing as mp
import time
import traceback
from pathlib import Path

import numpy as np

#: Catalogue pairs of the realistic set (each effect at SNR 40): the issue's weak pair
#: (delay + drift), cross-talk vs gain (sensing vs actuation), and mixtures of kinds.
PAIRS = (
    ("actuation_delay", "bias_drift"), ("sensing_cross_talk", "actuation_gain"),
    ("actuation_gain", "bias_drift"), ("cubic_stiffness", "glitch"),
    ("stiffness_drift", "actuation_delay"), ("geometry_error", "readout_scale"),
    ("rotation_coupling", "actuation_gain"), ("glitch", "bias_drift"),
    ("stiffness_cross_coupling", "actuation_quantisation"), ("readout_scale", "cubic_stiffness"),
    ("actuation_gain", "cubic_stiffness"), ("bias_drift", "stiffness_drift"),
)  # fmt: skip
SNR_LEVELS = (20.0, 60.0)
SNR_PAIR = 40.0
SNR_OOC = 40.0
#: An injected effect counts as identifiable when the scaler reached at least this SNR.
IDENTIFIABLE_SNR = 15.0
CALIBRATION_SEED_BASE = 20000


def _channel_and_options(name: str, rng: np.random.Generator) -> tuple[str, dict]:
    """The calibrated case of the effect, its sensitive axis drawn between x1 and x2."""
    from tmopt.mismatch.generate import MAGNITUDES

    cal = MAGNITUDES[name]
    ch, opt = cal["channel"], dict(cal["options"])
    if ch == "x1" and rng.random() < 0.5:
        ch = "x2"
    if name == "stiffness_cross_coupling" and rng.random() < 0.5:
        ch, opt = "y2", {"source": "x2"}
    if name == "sensing_cross_talk" and rng.random() < 0.5:
        ch, opt = "x1", {"source": "y1", "sensor": "disp"}
    return ch, opt


def cases(backend: str, seed_base: int, quick: bool, scaler: int | None = None) -> list[dict]:
    """The realistic set for one backend (150 recordings: 32 clean, 52 single catalogue
    effects, 24 pairs, 36 out-of-catalogue, 6 glitch storms; ``quick``: 5); ``scaler``: the
    SNR scaler's version (:data:`tmopt.mismatch.realistic.SCALER_VERSION` by default)."""
    from tmopt.mismatch.effects import EFFECT_NAMES
    from tmopt.mismatch.realistic import OUT_OF_CATALOGUE, SCALER_VERSION

    out: list[dict] = []
    seed = seed_base
    scaler = SCALER_VERSION if scaler is None else scaler

    def add(category: str, items: list[dict]) -> None:
        nonlocal seed
        out.append({"backend": backend, "category": category, "seed": seed, "items": items,
                    "scaler": scaler})  # fmt: skip
        seed += 1

    if quick:
        add("clean", [])
        add("catalogue", [{"kind": "effect", "name": "actuation_gain", "snr": 60.0}])
        add("catalogue", [{"kind": "effect", "name": "bias_drift", "snr": 60.0}])
        add("out-of-catalogue", [{"kind": "ooc", "name": "force_step", "snr": SNR_OOC}])
        add("pair", [{"kind": "effect", "name": "actuation_delay", "snr": SNR_PAIR},
                     {"kind": "effect", "name": "bias_drift", "snr": SNR_PAIR}])  # fmt: skip
        return out
    for _ in range(32):
        add("clean", [])
    for name in EFFECT_NAMES:
        for snr in SNR_LEVELS:
            for _ in range(2):
                add("catalogue", [{"kind": "effect", "name": name, "snr": snr}])
    for a, b in PAIRS:
        for _ in range(2):
            add("pair", [{"kind": "effect", "name": a, "snr": SNR_PAIR},
                         {"kind": "effect", "name": b, "snr": SNR_PAIR}])  # fmt: skip
    for name in OUT_OF_CATALOGUE:
        for _ in range(3):
            add("out-of-catalogue", [{"kind": "ooc", "name": name, "snr": SNR_OOC}])
    for _ in range(6):
        add("glitch-storm", [{"kind": "storm", "count": 3, "snr": 30.0}])
    return out


def build(case: dict):
    """Scenario, scaled injections, out-of-catalogue effects and the SNR of each."""
    from tmopt.mismatch.effects import EFFECTS, Injection
    from tmopt.mismatch.generate import MAGNITUDES
    from tmopt.mismatch.realistic import (
        _clean_cache,
        draw_glitches,
        draw_scenario,
        make_ooc,
        scale_to_snr,
    )

    backend, seed = case["backend"], case["seed"]
    sc = draw_scenario(seed, backend)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xBE]))
    clean = _clean_cache(sc, seed, backend, case.get("scaler", 1)) if case["items"] else None
    effects, ooc, snrs = [], [], []
    for item in case["items"]:
        if item["kind"] == "effect":
            name = item["name"]
            ch, opt = _channel_and_options(name, rng)
            sign = -1.0 if EFFECTS[name].signed and rng.random() < 0.5 else 1.0
            start = MAGNITUDES[name]["large"] * sign
            inj = Injection(name, float(start), ch, options=opt)
            inj, rho = scale_to_snr(sc, inj, item["snr"], seed, backend, clean)
            effects.append(inj)
            snrs.append(rho)
        elif item["kind"] == "ooc":
            name = item["name"]
            axis = str(rng.choice(["x1", "x2"]))
            o = make_ooc(name, _ooc_start(name), axis, seed, sc)
            if name != "acc_clipping":  # the clip level is a quantile, not scaled
                o, rho = scale_to_snr(sc, o, item["snr"], seed, backend, clean)
            else:
                from tmopt.mismatch.realistic import signature_snr

                rho = signature_snr(sc, (), [o], seed, backend, False, clean)
            ooc.append(o)
            snrs.append(rho)
        else:  # glitch storm: background glitches of LPF shapes, each scaled
            for g in draw_glitches(seed, sc, item["count"]):
                g, rho = scale_to_snr(sc, g, item["snr"], seed, backend, clean)
                effects.append(g)
                snrs.append(rho)
    return sc, effects, ooc, snrs


def limits(sc, effects, ooc, seed: int, backend: str) -> tuple[list[dict], list[dict]]:
    """Scorer only (the tool never sees it): per injected item alone in the recording --
    each catalogue effect of ``effects``, each of ``ooc`` -- ``{"visible", "distinct",
    "look_alike"}``; returns (per effect, per out-of-catalogue item).

    ``visible``: the SNR of the item's signature that the *nominal model leaves visible*,
    in the nominal fit's own metric -- the clean recording (same seed and gaps as the one
    diagnosed) prepared and fitted as the tool's first step does
    (:func:`tmopt.mismatch.diagnose.prepare`, ``fit_state``: clocks aligned, the noise
    model estimated from the recording's own residual), the item's change of both residual
    groups whitened by those noise models and cleared of the nominal columns (stiffness,
    bias and offsets per segment) -- the second attribution rate's SNR.  The scaler's SNR
    (:func:`tmopt.mismatch.realistic.signature_snr`) is an optimal filter's against the
    noise of two clean recordings' difference; it does not see what a stiffness fit
    absorbs (under a controller whose force is nearly proportional to the position an
    actuation gain is largely a stiffness change) nor the deterministic misfit a
    recording's own residual holds.

    ``distinct``: the SNR left after also projecting out the columns of the look-alike
    that absorbs most of it (``look_alike``) -- the physical limit (docs/mismatch.md
    9.13): for an out-of-catalogue item every catalogue candidate (a 1e-4 Hz modulation
    near its zero crossing is a drift within the record), for a catalogue effect every
    candidate of another name and every unnamed shape (:mod:`tmopt.mismatch.generic`:
    ``x|x|`` beside ``x^3``); candidates as the tool would test them on the item's
    recording, searched ones at their best variant for its residual, a twin tied as the
    tool ties it (:func:`_look_alike_columns`; the kinematic group by least squares where
    the tool uses instruments).

    All NaN for noise-like effects (no deterministic signature) and where the two
    recordings were prepared differently (another clock alignment)."""
    from tmopt.mismatch.diagnose import Settings, fit_state, prepare
    from tmopt.mismatch.effects import EFFECTS
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import realistic_recording

    def prepared(eff, oo):
        return prepare(data_from_recording(realistic_recording(sc, eff, oo, seed, backend)[0]))

    if not effects and not ooc:
        return [], []
    d0, basis = prepared((), ())
    state = fit_state(d0, basis, [], [], False, Settings())
    unknown = {"visible": math.nan, "distinct": math.nan, "look_alike": ""}
    per_effect = [dict(unknown) if EFFECTS[e.name].noise_like else
                  _limit(d0, basis, state, prepared([e], ())[0], e.name) for e in effects]
    per_ooc = [_limit(d0, basis, state, prepared((), [o])[0], None) for o in ooc]
    return per_effect, per_ooc


def _limit(d0, basis, state, d1, name: str | None) -> dict:
    """:func:`limits` of one item-only recording ``d1`` (``name``: its catalogue effect;
    None: an out-of-catalogue item)."""
    from tmopt.mismatch import generic
    from tmopt.mismatch.diagnose import Settings, fit_state
    from tmopt.mismatch.effects import CATALOGUE, Context

    groups = _changes(d0, basis, state, d1)
    if groups is None:
        return {"visible": math.nan, "distinct": math.nan, "look_alike": ""}
    s1 = fit_state(d1, basis, [], [], False, Settings())  # the look-alikes' search
    ctx = Context(d1, basis, s1.eq_fit.residual, s1.eq_noise)
    cands = [c for m in CATALOGUE for c in m.candidates(ctx)
             if c.group != "noise" and c.effect != name]  # fmt: skip
    if name is not None:
        cands += generic.candidates(ctx)
    best = (_snr_left(groups, []), "")
    visible = best[0]
    for cand in cands:
        label = cand.key if cand.effect != generic.GENERIC else \
            f"{cand.effect}:{cand.fixed.get('feature')}[{cand.channel}]"  # fmt: skip
        best = min(best, (_snr_left(groups, _look_alike_columns(cand)), label))
    return {"visible": visible, "distinct": best[0], "look_alike": best[1]}


def visible_snr(d0, basis, state, d1) -> float:
    """SNR of ``d1``'s change from the clean ``d0`` (both prepared) in ``state``'s (the
    nominal fit of ``d0``) whitened metric, both residual groups, with the nominal
    columns projected out; NaN where the two were prepared differently."""
    groups = _changes(d0, basis, state, d1)
    return math.nan if groups is None else _snr_left(groups, [])


def _changes(d0, basis, state, d1) -> dict | None:
    """``{group: (change of d1 from d0, whiten, nominal columns)}`` in ``state``'s (the
    nominal fit of ``d0``) metric, ``d1`` given ``d0``'s exact kinematics; None where the
    two were prepared differently (other samples or segments)."""
    from tmopt.mismatch.fit import equation_target, kinematic_target

    if d1.n != d0.n or list(d1.segments) != list(d0.segments):
        return None
    d1.stiffness, d1.acc_convention = d0.stiffness, d0.acc_convention
    d1.__dict__.pop("_x_eq", None)
    return {"equation": (equation_target(d1, basis) - equation_target(d0, basis),
                         state.eq_noise.whiten, state.eq_cols),
            "kinematic": (kinematic_target(d1) - kinematic_target(d0),
                          state.kin_noise.whiten, state.kin_cols)}  # fmt: skip


def _snr_left(groups: dict, extra: list[dict]) -> float:
    """SNR of the whitened changes ``groups`` (``{group: (change, whiten, nominal
    columns)}``) left after projecting out the nominal columns and the ``extra`` columns
    (each ``{group: Column}``: one coefficient, in one group or tied across both)."""
    from tmopt.mismatch.diagnose import _orth

    zs, xs = [], []
    for g, (change, whiten, cols) in groups.items():
        q = _orth(cols, whiten)

        def perp(v, q=q, whiten=whiten):
            v = whiten(v).ravel()
            return v - q @ (q.T @ v) if q.size else v

        zs.append(perp(change))
        xs.append(np.column_stack([perp(c[g].values) if g in c else np.zeros(zs[-1].size)
                                   for c in extra]) if extra else None)  # fmt: skip
    z = np.concatenate(zs)
    if extra:
        x = np.vstack(xs)
        x = x[:, np.linalg.norm(x, axis=0) > 0]  # no energy (a twin without tones): nothing
        if x.size:
            z = z - x @ np.linalg.lstsq(x, z, rcond=None)[0]
    return float(np.linalg.norm(z))


def _look_alike_columns(cand) -> list[dict]:
    """A candidate's columns for :func:`_snr_left`: its own group's, and an equation
    candidate's tested kinematic twin tied to its (single) coefficient -- the same
    parameter seen by both groups, as the tool tests it (``diagnose._joint``)."""
    cols = [{cand.group: c} for c in cand.columns]
    if cand.group == "equation" and cand.twin is not None and cand.twin_tested:
        if len(cols) == 1:
            cols[0]["kinematic"] = cand.twin
        else:  # several coefficients share the twin's one: left free (a lower bound)
            cols.append({"kinematic": cand.twin})
    return cols


def _ooc_start(name: str) -> float:
    from tmopt.mismatch.realistic import OUT_OF_CATALOGUE

    return OUT_OF_CATALOGUE[name].trial


def run_case(case: dict) -> dict:
    """Generate, diagnose, score one case; never raises (a traceback is a score)."""
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import realistic_recording
    from tmopt.mismatch.report import build_report

    ids = {"backend": case["backend"], "category": case["category"], "seed": case["seed"],
           "truth": "+".join(i.get("name", "storm") for i in case["items"]) or "clean"}  # fmt: skip
    t0 = time.process_time()
    try:
        sc, effects, ooc, snrs = build(case)
        rec, truth = realistic_recording(sc, effects, ooc, case["seed"], case["backend"])
    except Exception as exc:  # a diverged loop is reported, not hidden
        return {**ids, "error": f"generation: {type(exc).__name__}: {exc}"}
    truth["snr"], truth["scaler_version"] = snrs, case.get("scaler", 1)
    per_effect, per_ooc = limits(sc, effects, ooc, case["seed"], case["backend"])
    truth["snr_nominal"] = [d["visible"] for d in per_effect]
    truth["ooc_distinct"], truth["effect_distinct"] = per_ooc, per_effect
    try:
        rep = build_report(diagnose(data_from_recording(rec), _settings(case)))
    except Exception:  # noqa: BLE001 - a traceback is what this benchmark counts
        return {**ids, "traceback": traceback.format_exc(limit=3)}
    row = {**ids, **score(rep, truth), "cpu_s": time.process_time() - t0,
           "duration": sc.duration, "fs": sc.sample_rate, "gaps": len(sc.gaps),
           "snr": ";".join(f"{v:.1f}" for v in snrs),
           "snr_nominal": ";".join(f"{v:.1f}" for v in truth["snr_nominal"])}  # fmt: skip
    if case.get("keep"):
        name = f"{case['backend']}_{case['category']}_{case['seed']}"
        Path(case["keep"], f"{name}.report.json").write_text(json.dumps(rep, default=float))
        Path(case["keep"], f"{name}.truth.json").write_text(json.dumps(truth, default=str))
    return row


def _settings(case: dict):
    """The tool's settings a case is diagnosed with (``--setting``), None: the defaults."""
    from tmopt.mismatch.diagnose import Settings

    return Settings(**case["settings"]) if case.get("settings") else None


def score(rep: dict, truth: dict) -> dict:
    """Per recording: what the tool said against what was concealed."""
    names = [e["name"] for e in rep.get("effects", [])]
    true_names = {e["name"] for e in truth["effects"]}
    snr = truth.get("snr", [])
    testable = [e for e, s in zip(truth["effects"], snr)
                if s >= IDENTIFIABLE_SNR and not _untestable(rep, e["name"])]  # fmt: skip
    extra = [n for n in names if n not in true_names]
    unexpl = rep.get("unexplained_at", {}) or {}
    chans = unexpl.get("channels", []) if rep.get("unexplained") else []
    row = {
        "refused": rep.get("status") == "cannot_diagnose",
        "detected": bool(rep.get("mismatch_detected")),
        "found": ";".join(f"{e['name']}[{e['channel']}]" for e in rep.get("effects", [])),
        "unexplained": bool(rep.get("unexplained")),
        "unexplained_channels": ";".join(chans),
        "n_true": len(truth["effects"]), "n_identifiable": len(testable),
        "n_ooc": len(truth.get("out_of_catalogue", [])),
        "extra_names": len(extra), "wrong": bool(extra),
        "ambiguous": ";".join(r["name"] for r in rep.get("not_identifiable", [])
                              if r.get("reason") == "ambiguous"),
    }  # fmt: skip
    row["all_named"] = all(e["name"] in names for e in testable)
    row["attributed"] = bool(testable) and row["all_named"] and not extra
    if "snr_nominal" in truth:  # second rate: identifiable by what the nominal fit leaves
        # (noise-like effects have no deterministic signature to project: the scaler's SNR)
        nominal = [v if math.isfinite(v) else s for v, s in zip(truth["snr_nominal"], snr)]
        seen = [e for e, s in zip(truth["effects"], nominal)
                if s >= IDENTIFIABLE_SNR and not _untestable(rep, e["name"])]  # fmt: skip
        row["n_identifiable_nominal"] = len(seen)
        row["attributed_nominal"] = bool(seen) and all(e["name"] in names for e in seen) \
            and not extra  # fmt: skip
    if truth.get("ooc_distinct") is not None:  # second rates: the physical limit
        row.update(_distinct_scores(rep, truth, extra))
    if truth.get("effect_distinct") is not None:
        dist = [d["distinct"] for d in truth["effect_distinct"]]
        # NaN (noise-like, or prepared differently): as the scaler saw it
        seen = [e for e, s, d in zip(truth["effects"], snr, dist)
                if s >= IDENTIFIABLE_SNR and not d < IDENTIFIABLE_SNR
                and not _untestable(rep, e["name"])]  # fmt: skip
        row["n_identifiable_distinct"] = len(seen)
        row["attributed_distinct"] = bool(seen) and all(e["name"] in names for e in seen) \
            and not extra  # fmt: skip
        row["effect_distinct"] = ";".join(f"{d:.1f}" for d in dist)
        row["effect_look_alike"] = ";".join(d["look_alike"] for d in truth["effect_distinct"])
    row["false_alarm"] = not truth["effects"] and not truth.get("out_of_catalogue") and bool(
        rep.get("mismatch_detected"))
    oocs = truth.get("out_of_catalogue", [])
    if oocs:
        axes = {o["axis"] for o in oocs}
        at_axis = any(any(c == a or c.startswith(a + " ") for c in chans) for a in axes)
        row["ooc_unexplained_right_channel"] = bool(rep.get("unexplained")) and at_axis \
            and not names  # fmt: skip
    return row


def _distinct_scores(rep: dict, truth: dict, extra: list[str]) -> dict:
    """Scores against what the data can tell (:func:`limits`): an out-of-catalogue
    item whose ``distinct`` SNR is below IDENTIFIABLE_SNR is, within the record's
    precision, its look-alike catalogue effect -- naming that effect at that channel is
    not counted wrong, and the item is not counted in the out-of-catalogue rate.  The
    headline rates keep every recording."""
    dist = truth["ooc_distinct"]
    same = {d["look_alike"] for d in dist if d["distinct"] < IDENTIFIABLE_SNR}  # NaN: kept
    wrong = [e for e in rep.get("effects", [])
             if e["name"] in extra and f"{e['name']}[{e['channel']}]" not in same]  # fmt: skip
    out = {"ooc_distinct": ";".join(f"{d['distinct']:.1f}" for d in dist),
           "ooc_look_alike": ";".join(d["look_alike"] for d in dist),
           "wrong_distinct": bool(wrong),
           "wrong_distinct_ties": any(not _tie_excused(e, same) for e in wrong)}  # fmt: skip
    if dist:
        out["ooc_distinguishable"] = all(d["distinct"] >= IDENTIFIABLE_SNR for d in dist)
    return out


def _tie_excused(effect: dict, same: set[str]) -> bool:
    """The added line of docs/mismatch.md 9.35 (written before its rows were read): a
    name whose flagged ``channel_alternatives`` (the force's channel the data barely
    chose) hold its look-alike's channel is not counted wrong against the limit in that
    line.  A name that matches a catalogue truth is never extra (names are scored without
    channels), so the rule's "or the truth's channel" has nothing to act on here."""
    return any(f"{effect['name']}[{c}]" in same for c in effect.get("channel_alternatives") or [])


def _rescored(row: dict, reports: Path, distinct: dict | None = None) -> dict:
    """``row`` scored again from its kept report and truth (the rows file is not changed;
    a row without them, or a traceback, is returned as it was).  ``distinct``: the
    :func:`limits` computed afterwards for a run made before they existed
    (``--distinct``), by ``(backend, seed)``."""
    name = f"{row['backend']}_{row['category']}_{row['seed']}"
    rep, tru = reports / f"{name}.report.json", reports / f"{name}.truth.json"
    if "traceback" in row or "error" in row or not (rep.exists() and tru.exists()):
        return row
    truth = json.loads(tru.read_text())
    key = (row["backend"], row["seed"])
    if distinct is not None and "ooc_distinct" not in truth:
        if key in distinct or not truth.get("out_of_catalogue"):
            truth["ooc_distinct"] = distinct.get(key, {}).get("ooc_distinct", [])
    if distinct is not None and "effect_distinct" not in truth and \
            "effect_distinct" in distinct.get(key, {}):  # fmt: skip
        truth["effect_distinct"] = distinct[key]["effect_distinct"]
    return {**row, **score(json.loads(rep.read_text()), truth)}


def distinct_job(job: tuple[str, int, int, int]) -> dict:
    """:func:`limits` of one benchmark case ``(backend, seed base, seed, scaler version)``."""
    backend, base, seed, scaler = job
    case = next(c for c in cases(backend, base, False, scaler) if c["seed"] == seed)
    sc, effects, ooc, _ = build(case)
    per_effect, per_ooc = limits(sc, effects, ooc, seed, backend)
    return {"backend": backend, "seed": seed, "ooc_distinct": per_ooc,
            "effect_distinct": per_effect}  # fmt: skip


def backfill_distinct(out: Path, base: int, jobs: int, scaler: int) -> dict:
    """``--distinct``: :func:`limits` of every row of a run made before the scorer had
    them that holds an out-of-catalogue item or an identifiable effect, streamed to
    ``realistic_ooc_distinct.jsonl`` (resumable); returns them by ``(backend, seed)``."""
    path = out / "realistic_ooc_distinct.jsonl"
    have = [json.loads(x) for x in path.read_text().splitlines() if x] if path.exists() else []
    done = {(r["backend"], r["seed"]) for r in have if "effect_distinct" in r}
    rows = [json.loads(x) for x in (out / "realistic_rows.jsonl").read_text().splitlines() if x]
    todo = [(r["backend"], base, r["seed"], scaler) for r in rows
            if (r.get("n_ooc") or r.get("n_identifiable"))
            and (r["backend"], r["seed"]) not in done]  # fmt: skip
    with open(path, "a") as fh, mp.get_context("spawn").Pool(max(1, min(jobs, len(todo)))) as pool:
        for i, rec in enumerate(pool.imap_unordered(distinct_job, todo)):
            have.append(rec)
            fh.write(json.dumps(rec, default=float) + "\n")
            fh.flush()
            print(f"[distinct {i + 1}/{len(todo)}] {rec['backend']} {rec['seed']}: "
                  + ", ".join(f"{d['distinct']:.1f} ({d['look_alike']})"
                              for d in rec["effect_distinct"] + rec["ooc_distinct"]),
                  flush=True)  # fmt: skip
    by = {}
    for r in have:  # a later record (with effect_distinct) completes an earlier one
        by.setdefault((r["backend"], r["seed"]), {}).update(r)
    return by


def _untestable(rep: dict, name: str) -> bool:
    return any(r["name"] == name and str(r.get("reason", "")).startswith("untestable")
               for r in rep.get("not_identifiable", []))  # fmt: skip


def _frac(k: int, n: int) -> str:
    return f"{k}/{n} ({100 * k / n:.0f} %)" if n else "—"


def _nominal_line(ok: list[dict]) -> list[str]:
    """The second attribution rate (rows scored with ``snr_nominal`` only): identifiable =
    SNR >= IDENTIFIABLE_SNR after the nominal fit (:func:`limits`' ``visible``); the headline
    rate above keeps every recording."""
    have = [r for r in ok if "n_identifiable_nominal" in r]
    if not have:
        return []
    ident = [r for r in have if r["n_identifiable_nominal"]]
    att = sum(r["attributed_nominal"] for r in ident)
    return [f"| attribution, identifiable after the nominal fit (second rate; {len(have)} rows "
            f"carry it) | {_frac(att, len(ident))} | >= 95 % |"]  # fmt: skip


def _distinct_lines(ok: list[dict], ooc: list[dict]) -> list[str]:
    """Second rates against what the data can tell (rows scored with :func:`limits`
    only, :func:`_distinct_scores`); the
    headline rates above keep every recording."""
    out = []
    carry = [r for r in ok if "n_identifiable_distinct" in r]
    if carry:
        ident = [r for r in carry if r["n_identifiable_distinct"]]
        out.append("| attribution, identifiable and distinguishable from every look-alike of "
                   f"another name, catalogue or unnamed (second rate; {len(carry)} rows "
                   f"carry it) | {_frac(sum(r['attributed_distinct'] for r in ident), len(ident))}"
                   " | >= 95 % |")  # fmt: skip
    have = [r for r in ok if "wrong_distinct" in r]
    if not have:
        return out
    seen = [r for r in ooc if r.get("ooc_distinguishable")]
    oo = sum(bool(r.get("ooc_unexplained_right_channel")) for r in seen)
    n_ooc = sum("ooc_distinguishable" in r for r in ooc)
    return out + [
        "| out-of-catalogue at the right channel, no name -- items distinguishable from "
        f"every single catalogue effect (second rate; {len(seen)} of {n_ooc} are) | "
        f"{_frac(oo, len(seen))} | >= 90 % |",
        "| recordings with a wrong name, a look-alike the data cannot tell from its "
        f"out-of-catalogue truth not counted (second rate; {len(have)} rows carry it) | "
        f"{_frac(sum(r['wrong_distinct'] for r in have), len(have))} | <= 1 % |",
        *_tie_lines(ok)]


def _tie_lines(ok: list[dict]) -> list[str]:
    """The added lines of docs/mismatch.md 9.35, beside (never replacing) the limit's:
    a flagged channel tie whose alternative holds the look-alike's channel is not counted
    wrong.  Attribution scores names without channels, so its added line is the limit's
    attribution line itself, said so rather than recomputed."""
    have = [r for r in ok if "wrong_distinct_ties" in r]
    if not have:
        return []
    return ["| recordings with a wrong name against the limit, a name whose flagged channel "
            "tie holds its look-alike's channel not counted (added line, 9.35; "
            f"{len(have)} rows carry it) | "
            f"{_frac(sum(r['wrong_distinct_ties'] for r in have), len(have))} | <= 1 % |",
            "| attribution with flagged channel ties counted (added line, 9.35): names are "
            "scored without channels, so it is the limit's attribution line above | = | - |"]


def summarise(rows: list[dict]) -> str:
    lines = []
    for backend in sorted({r["backend"] for r in rows}):
        sel = [r for r in rows if r["backend"] == backend]
        ok = [r for r in sel if "error" not in r and "traceback" not in r]
        clean = [r for r in ok if r["category"] == "clean"]
        ident = [r for r in ok if r.get("n_identifiable")]
        ooc = [r for r in ok if r["category"] == "out-of-catalogue"]
        lines += [f"### Backend `{backend}` ({len(sel)} recordings)", "",
                  "| measure | result | target |", "|---|---|---|"]  # fmt: skip
        fa = sum(r["false_alarm"] for r in clean)
        att = sum(r["attributed"] for r in ident)
        oo = sum(bool(r.get("ooc_unexplained_right_channel")) for r in ooc)
        lines += [
            f"| false alarms (clean) | {_frac(fa, len(clean))} | <= 2 % |",
            "| attribution, no extra name (identifiable catalogue effects) | "
            f"{_frac(att, len(ident))} | >= 95 % |",
            "| out-of-catalogue reported unexplained at the right channel, no name | "
            f"{_frac(oo, len(ooc))} | >= 90 % |",
            "| recordings with a wrong (extra) name | "
            f"{_frac(sum(r['wrong'] for r in ok), len(ok))} | <= 1 % |",
            *_nominal_line(ok),
            *_distinct_lines(ok, ooc),
            f"| refused (cannot diagnose) | {_frac(sum(r['refused'] for r in ok), len(ok))} | 0 |",
            f"| tracebacks | {sum('traceback' in r for r in sel)} | 0 |",
            f"| generation failures (diverged loops) | {sum('error' in r for r in sel)} | - |",
        ]
        lines += ["", "| category / truth | n | named all | extra names | unexplained | "
                  "ooc at right channel |", "|---|---|---|---|---|---|"]  # fmt: skip
        for key in sorted({(r["category"], r["truth"]) for r in ok}):
            rr = [r for r in ok if (r["category"], r["truth"]) == key]
            lines.append(
                f"| {key[0]} / {key[1]} | {len(rr)} | "
                f"{sum(r['all_named'] and r['n_identifiable'] > 0 for r in rr)}"
                f"/{sum(r['n_identifiable'] > 0 for r in rr)} | "
                f"{sum(r['extra_names'] for r in rr)} | {sum(r['unexplained'] for r in rr)} | "
                f"{sum(bool(r.get('ooc_unexplained_right_channel')) for r in rr)} |")  # fmt: skip
        lines.append("")
    return "\n".join(lines)


def parse_only(spec: str, flag: str = "--only") -> set[tuple[str | None, int]]:
    """``--only`` (or another ``flag`` naming recordings the same way): comma-separated
    ``SEED`` (both simulators) or ``BACKEND:SEED``; raises ValueError naming the bad item."""
    out: set[tuple[str | None, int]] = set()
    for item in filter(None, (x.strip() for x in spec.split(","))):
        backend, _, seed = item.rpartition(":")
        if backend not in ("", "kernel", "foreign") or not seed.isdigit():
            raise ValueError(f"{flag}: {item!r} is not SEED or kernel:SEED or foreign:SEED")
        out.add((backend or None, int(seed)))
    if not out:
        raise ValueError(f"{flag}: give at least one SEED or BACKEND:SEED")
    return out


def parse_records(text: str, flag: str = "--records") -> list[tuple[str, int]]:
    """``flag`` (a list of recordings) read as the benchmark's ``--only`` (:func:`parse_only`:
    ``SEED`` for both simulators, or ``BACKEND:SEED``) -> sorted [(backend, seed)], every
    seed a benchmark seed (>= 40000); a bad item raises SystemExit naming it."""
    try:
        keys = parse_only(text, flag)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None
    low = sorted(seed for _, seed in keys if seed < 40000)
    if low:
        raise SystemExit(f"{flag}: seeds must be benchmark seeds (>= 40000); got {low}")
    both = ("kernel", "foreign")
    return sorted({(b, seed) for backend, seed in keys for b in ((backend,) if backend else both)})


def only(todo: list[dict], spec: str) -> list[dict]:
    """The cases of ``todo`` that ``--only`` names (order kept)."""
    keys = parse_only(spec)
    return [c for c in todo
            if (c["backend"], c["seed"]) in keys or (None, c["seed"]) in keys]  # fmt: skip


def parse_settings(items: list[str] | None) -> dict:
    """``--setting NAME=VALUE`` (repeatable): the tool's settings the run diagnoses with
    (fields of :class:`tmopt.mismatch.diagnose.Settings`; a flag is ``true``/``false``, a
    tuple comma-separated), checked by constructing them; raises ValueError naming the bad
    item and what it allows."""
    from dataclasses import fields

    from tmopt.mismatch.diagnose import Settings

    names = sorted(f.name for f in fields(Settings))
    defaults, out = Settings(), {}
    for item in items or []:
        name, sep, text = item.partition("=")
        name = name.strip().replace("-", "_")
        if not sep or name not in names:
            raise ValueError(f"--setting: {item!r} is not NAME=VALUE with NAME one of "
                             f"{', '.join(names)}")  # fmt: skip
        out[name] = _setting_value(name, text.strip(), getattr(defaults, name))
    try:
        Settings(**out)
    except ValueError as exc:
        raise ValueError(f"--setting: {exc}") from None
    return out


def _setting_value(name: str, text: str, default):
    """``text`` read as ``default``'s type (a bool, int, float, tuple of str or str)."""
    if isinstance(default, bool):
        if text.lower() not in ("true", "false"):
            raise ValueError(f"--setting: {name} must be true or false; got {text!r}")
        return text.lower() == "true"
    if isinstance(default, tuple):
        return tuple(x.strip() for x in text.split(",") if x.strip())
    try:
        return type(default)(text)
    except ValueError:
        raise ValueError(f"--setting: {name} must be a {type(default).__name__}; "
                         f"got {text!r}") from None  # fmt: skip


def _run_settings(out: Path, asked: dict, running: bool) -> dict:
    """The tool's settings of the run in ``out`` (``--setting``; ``{}``: the defaults of the
    code that ran), kept in ``realistic_meta.json`` beside the scaler's version, with every
    setting they came to (``effective``: a default may change between stops, as
    ``kin_profile`` did at stop 55).  A run resumed with other effective settings would mix
    two tools in one table, so that is an error, as is resuming a run that did not keep
    them (its defaults are not known).  A run that simulates nothing (``--summarise``)
    only reads them; a run made before they were kept is read as the defaults and its
    record is left as it is."""
    meta_path = out / "realistic_meta.json"
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
    have, wanted = meta.get("settings"), effective_settings(asked)
    if have is None and not (out / "realistic_rows.jsonl").exists():  # a new run
        have, meta = asked, {**meta, "settings": asked, "effective": wanted}
        meta_path.write_text(json.dumps(meta, indent=1))
    elif have is None:  # made before settings were kept: not written for it
        have = {}
    if not running:
        return have
    kept = meta.get("effective")
    if kept is None:
        raise SystemExit(f"error: the run in {out} did not keep the settings it ran with "
                         f"(made by {meta.get('commit', 'an older commit')}, whose defaults "
                         f"may differ); resume it with that code, or use another --out")
    if kept != wanted:
        differ = sorted(k for k in set(kept) | set(wanted) if kept.get(k) != wanted.get(k))
        raise SystemExit(f"error: --setting {_settings_text(asked)} runs the tool with "
                         f"{_values_text(wanted, differ)}, but the run in {out} was made "
                         f"with {_values_text(kept, differ)}; use another --out")
    return asked


def effective_settings(asked: dict) -> dict:
    """Every field of :class:`tmopt.mismatch.diagnose.Settings` that ``asked`` comes to
    with this code's defaults, as JSON keeps it (a tuple as a list)."""
    from dataclasses import asdict

    from tmopt.mismatch.diagnose import Settings

    return json.loads(json.dumps(asdict(Settings(**asked))))


def _values_text(settings: dict, names: list[str]) -> str:
    return " ".join(f"{k}={settings.get(k, '(absent)')}" for k in names)


def _settings_text(settings: dict) -> str:
    return " ".join(f"{k}={v}" for k, v in sorted(settings.items())) or "the defaults"


def _run_scaler(out: Path, asked: int | None, code: dict) -> int:
    """The SNR scaler version of the run in ``out``: kept in ``realistic_meta.json`` so a
    resumed or re-scored run regenerates its own recordings.  A run made before the file
    existed used version 1; asking for another version there is an error.  ``code``: this
    process' :func:`provenance`, kept with a new run's version."""
    from tmopt.mismatch.realistic import SCALER_VERSION

    meta = out / "realistic_meta.json"
    if meta.exists():
        have = json.loads(meta.read_text())["scaler_version"]
    elif (out / "realistic_rows.jsonl").exists():
        have = 1
    else:
        have = SCALER_VERSION if asked is None else asked
        meta.write_text(json.dumps({"scaler_version": have, **code}, indent=1))
    if asked is not None and asked != have:
        raise SystemExit(f"error: --scaler-version {asked}, but the run in {out} was made with "
                         f"version {have}; use another --out")
    return have


def provenance() -> dict:
    """Which code ran: the imported package's folder and its git commit (a run started in
    a git worktree imports the *editable install's* tmopt unless PYTHONPATH names the
    worktree -- two arms of a paired run would then run one code), and the libraries."""
    import subprocess

    import tmopt
    from tmopt.run.outputs import library_versions

    src = Path(tmopt.__file__).resolve().parent
    try:
        commit = subprocess.run(["git", "-C", str(src), "describe", "--always", "--dirty"],
                                capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return {"tmopt": str(src), "commit": commit or "unknown", "versions": library_versions()}


def main_realistic(args) -> int:
    out = Path(args.out)
    (out / "realistic_reports").mkdir(parents=True, exist_ok=True)
    backends = ("kernel", "foreign") if args.backend == "both" else (args.backend,)
    code = provenance()
    scaler = _run_scaler(out, getattr(args, "scaler_version", None), code)
    settings = _run_settings(out, getattr(args, "settings", None) or {},
                             not getattr(args, "summarise", False))  # fmt: skip
    print(f"tmopt from {code['tmopt']} at {code['commit']}; SNR scaler version {scaler}; "
          f"settings: {_settings_text(settings)}", flush=True)  # fmt: skip
    todo = [c for b in backends for c in cases(b, args.seed_base, args.quick, scaler)]
    # a fixed shuffle: a run stopped early has scored every category and both simulators
    todo = [todo[i] for i in np.random.default_rng(0).permutation(len(todo))]
    if getattr(args, "only", None):
        todo = only(todo, args.only)
    for c in todo:
        c["keep"], c["settings"] = str(out / "realistic_reports"), settings
    rows = []
    done_path = out / "realistic_rows.jsonl"  # every row as it comes (nothing lost)
    if done_path.exists():  # resume: a killed run keeps what it scored
        rows = [json.loads(line) for line in done_path.read_text().splitlines() if line]
        done = {(r["backend"], r["seed"]) for r in rows}
        todo = [c for c in todo if (c["backend"], c["seed"]) not in done]
        print(f"resuming: {len(rows)} recordings already scored", flush=True)
    if getattr(args, "summarise", False):  # score what is there, run nothing
        todo = []
    distinct = None
    if getattr(args, "distinct", False):  # the physical limit, for a run made before it
        distinct = backfill_distinct(out, args.seed_base, args.jobs, scaler)
    if getattr(args, "rescore", False) or distinct is not None:
        # today's scorer on the kept reports and truths
        rows = [_rescored(r, out / "realistic_reports", distinct) for r in rows]
    stream = open(done_path, "a")
    with stream, mp.get_context("spawn").Pool(min(args.jobs, max(len(todo), 1))) as pool:
        for row in pool.imap_unordered(run_case, todo):
            rows.append(row)
            stream.write(json.dumps(row, default=float) + "\n")
            stream.flush()
            what = row.get("found") or ("unexplained " + row.get("unexplained_channels", "")
                                        if row.get("unexplained") else "-")  # fmt: skip
            if "error" in row or "traceback" in row:
                what = (row.get("error") or row["traceback"]).splitlines()[-1]
            print(f"[{len(rows)}] {row['backend']} {row['category']} {row['truth']} "
                  f"-> {what}", flush=True)  # fmt: skip
    keys = sorted({k for r in rows for k in r})
    with open(out / "realistic.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    text = summarise(rows)
    (out / "realistic.md").write_text(text)
    print(text)
    if getattr(args, "paired_with", None):  # the same recordings scored by an earlier run
        other = [json.loads(x) for x in
                 (Path(args.paired_with) / "realistic_rows.jsonl").read_text().splitlines() if x]
        mine = {(r["backend"], r["seed"]) for r in rows}
        both = mine & {(r["backend"], r["seed"]) for r in other}
        print(f"## Paired on the {len(both)} recordings both runs scored\n\n### {args.out}\n")
        print(summarise([r for r in rows if (r["backend"], r["seed"]) in both]))
        print(f"### {args.paired_with}\n")
        print(summarise([r for r in other if (r["backend"], r["seed"]) in both]))
    cpu = [r["cpu_s"] for r in rows if "cpu_s" in r]
    if cpu:
        print(f"{len(rows)} recordings; CPU per recording: median {np.median(cpu):.1f} s, "
              f"total {sum(cpu) / 3600:.2f} h")  # fmt: skip
    return 0


# ----------------------------------------------------------------------- calibration


def clean_recording(seed: int, backend: str):
    """A clean flight-like recording of ``backend``: scenario and noise drawn from
    ``seed`` (a calibration null's record)."""
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording

    return realistic_recording(draw_scenario(seed, backend), (), (), seed, backend)[0]


def rows_done(out: Path) -> set:
    """``(backend, seed)`` of the rows already in ``out`` (JSON lines; empty if none)."""
    return {(r["backend"], r["seed"]) for r in map(json.loads, out.open())} \
        if out.exists() else set()  # fmt: skip


def per_recording(seed_base: int, n: int, out: Path, job, show=None) -> None:
    """``job(backend, seed, i) -> row`` for seeds ``seed_base .. + n`` of both simulators,
    each row streamed to ``out`` (JSON lines) and printed (``show(row) -> str``, default
    the row itself); resumable: rows already there are skipped."""
    out.parent.mkdir(parents=True, exist_ok=True)
    done = rows_done(out)
    with out.open("a") as fh:
        for i in range(n):
            for b in ("kernel", "foreign"):
                seed = seed_base + i
                if (b, seed) in done:
                    continue
                row = {"backend": b, "seed": seed, **job(b, seed, i)}
                fh.write(json.dumps(row) + "\n")
                fh.flush()
                print(show(row) if show else json.dumps(row), flush=True)


def add_null_parser(sub, name: str, seed_base: int, n: int, out: str) -> None:
    """A calibration null's subcommand (``--seed-base``, ``--n``, ``--out``) for
    :func:`per_recording`; :func:`null_args_error` checks it."""
    p = sub.add_parser(name)
    p.add_argument("--seed-base", type=int, default=seed_base)
    p.add_argument("--n", type=int, default=n)
    p.add_argument("--out", default=out)


def null_args_error(args) -> str | None:
    """One line naming what is out of range in a null's arguments, or None."""
    if args.n < 1 or not 0 <= args.seed_base < 40000:
        return "--n must be >= 1 and --seed-base in [0, 40000) (calibration seeds)"
    return None


def case_recording(backend: str, seed: int):
    """Benchmark recording ``seed`` of ``backend`` (its set's seed base: the seed rounded
    down to 10000), made as the benchmark makes it: ``(recording, truth)``."""
    [case] = [c for c in cases(backend, seed // 10000 * 10000, False) if c["seed"] == seed]
    return _made(case)[:2]


def _made(case: dict):
    """A case's ``(recording, truth, snrs)``: its scenario and items scaled (:func:`build`),
    then recorded."""
    from tmopt.mismatch.realistic import realistic_recording

    sc, effects, ooc, snrs = build(case)
    rec, truth = realistic_recording(sc, effects, ooc, case["seed"], case["backend"])
    return rec, truth, snrs


def diagnosed_case(case: dict, settings=None):
    """Generate a case's recording and diagnose it (``settings``: the tool's, default its
    defaults): ``(diagnosis, snrs, None)``, or ``(None, None, "generation: ...")`` when the
    generator's loop diverged (reported, not hidden)."""
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording

    try:
        rec, _, snrs = _made(case)
    except Exception as exc:
        return None, None, f"generation: {exc}"
    return diagnose(data_from_recording(rec), settings), snrs, None


def calibration_cli(description: str, n_default: int, out_default: str, argv=None,
                    extra: dict | None = None):
    """The command line of a calibration script (``--n`` rounds, ``--jobs``, ``--out``,
    and the script's own ``extra`` options: ``{flag: argparse keywords}``): the parsed
    arguments, or None after one line on stderr for a bad count."""
    import argparse
    import sys

    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--n", type=int, default=n_default, help="rounds of the set per simulator")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default=out_default)
    for flag, kw in (extra or {}).items():
        ap.add_argument(flag, **kw)
    a = ap.parse_args(argv)
    if a.n < 1 or a.jobs < 1:
        print("--n and --jobs must be integers >= 1", file=sys.stderr)
        return None
    return a


def streamed_rows(path: Path, todo: list[dict], run, jobs: int = 1,
                  key=lambda r: (r["set"], r["backend"], r["seed"])) -> list[dict]:  # fmt: skip
    """Run ``run`` on the jobs of ``todo`` not yet in the JSON-lines file ``path`` (a
    stopped calibration resumes), appending each row as it comes (nothing lost); every
    row of the file, in its order."""
    path.parent.mkdir(parents=True, exist_ok=True)
    done = {key(r) for r in map(json.loads, path.open())} if path.exists() else set()
    todo = [j for j in todo if key(j) not in done]
    with path.open("a") as fh:
        it = map(run, todo) if jobs == 1 else mp.Pool(jobs).imap_unordered(run, todo)
        for row in it:
            fh.write(json.dumps(row, default=float) + "\n")
            fh.flush()
            print(json.dumps(row, default=float), flush=True)
    return [json.loads(x) for x in path.open()]


def calibration_job(job: tuple[str, int] | dict) -> dict:
    """One clean realistic recording under the tool's defaults: the first greedy step's
    smallest Holm p, the locate step's smallest adjusted p, the benchmark's false alarm
    (the report says a mismatch) and what raised it -- each name and each unexplained
    feature with its statistic (GLR, Holm p, trials) -- for calibrating a family's null."""
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording
    from tmopt.mismatch.report import build_report

    backend, seed = (job["backend"], job["seed"]) if isinstance(job, dict) else job
    sc = draw_scenario(seed, backend)
    rec, _ = realistic_recording(sc, (), (), seed, backend)
    dg = diagnose(data_from_recording(rec))
    if dg.refused:
        return {"backend": backend, "seed": seed, "refused": dg.refused, "min_p_holm": math.nan,
                "min_p_key": "", "locate_p": math.nan, "detected_default": None,
                "false_alarm": None, "raised": []}  # fmt: skip
    rep = build_report(dg)
    best = min(dg.steps[0], key=lambda e: e.p_holm)
    raised = [{"what": e["name"], "channel": e["channel"], **_stat(e["evidence"])}
              for e in rep["effects"]]
    raised += [{"what": f["feature"], "channel": f["channel"], **_stat(f.get("evidence", {}))}
               for f in rep.get("features", [])]  # fmt: skip
    return {"backend": backend, "seed": seed, "refused": "", "min_p_holm": best.p_holm,
            "min_p_key": best.candidate.key, "locate_p": dg.locations.min_p,
            "detected_default": dg.mismatch_detected,
            "false_alarm": bool(rep.get("mismatch_detected")), "raised": raised,
            "unexplained_channels": (rep.get("unexplained_at") or {}).get("channels", []),
            "duration": sc.duration, "fs": sc.sample_rate, "gaps": len(sc.gaps),
            "force_stamp": sc.force_stamp, "acc_convention": sc.acc_convention}  # fmt: skip


def _stat(ev: dict) -> dict:
    return {k: ev.get(k) for k in ("glr", "p_holm", "delta_bic", "trials")}


def calibration_jobs(n: int, seed_base: int = CALIBRATION_SEED_BASE) -> list[tuple[str, int]]:
    return [(b, seed_base + i) for i in range(n) for b in ("kernel", "foreign")]

