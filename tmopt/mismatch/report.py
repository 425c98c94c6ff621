"""Reports of a diagnosis: ``report.json`` (schema: docs/mismatch-report-schema.md),
``report.md`` for people, and PNG plots (residual spectrum and time series before/after,
with the located bands and windows shaded)."""

from __future__ import annotations

import json
import math
import re
from dataclasses import fields
from pathlib import Path

import numpy as np

from tmopt.mismatch import calibration as cal
from tmopt.mismatch import generic
from tmopt.mismatch.diagnose import (
    Diagnosis,
    State,
    effect_parameters,
    event_pieces,
    shares_axis,
    stiffness,
    summary,
)
from tmopt.mismatch.effects import CATALOGUE
from tmopt.mismatch.fit import AXES
from tmopt.mismatch.locate import tone_transfer, witness_coherence

__all__ = ["SCHEMA_VERSION", "build_report", "write_report", "conclusion"]

SCHEMA_VERSION = 1
_NEEDS = {e.name: e.needs for e in CATALOGUE}


def _effect_entry(dg: Diagnosis, ev, alts) -> dict:
    cand = ev.candidate
    if cand.group == "noise":
        fs = dg.data.fs
        red = dg.after.eq_noise.red
        params = {"knee_hz": [k * fs for k, _, _ in red], "exponent": [g for _, g, _ in red]}
        unc: dict = {}
    else:
        phys = effect_parameters(dg.after, cand)
        params = {k: v for k, (v, _) in phys.items()}
        unc = {k: s for k, (_, s) in phys.items()}
        params.update(cand.fixed)
    return {
        "name": cand.effect,
        "channel": cand.channel,
        "parameters": params,
        "uncertainties": unc,
        "units": dict(zip(cand.params, cand.units)),
        "evidence": {
            "delta_bic": ev.dbic, "glr": ev.glr, "dof": ev.dof, "p_value": ev.p_value,
            "p_holm": ev.p_holm, "trials": cand.trials,
            "alternatives": [{"name": a.candidate.effect, "channel": a.candidate.channel,
                              "delta_bic": a.dbic} for a in alts],
        },  # fmt: skip
        "channel_alternatives": channel_alternatives(ev, alts),
        "explanation": cand.text,
    }


def channel_alternatives(ev, alts) -> list[str]:
    """The other channels of a force the data barely chose between: the same effect on
    another channel among the near alternatives (``alts``: within AMBIGUOUS_DBIC at its
    step) when the effect is a force (equation group), whose f_B-free rows mix every
    axis.  A bias drift on x1 and one on y2 can fit one slow change within a BIC unit,
    and below a margin of 2.5 the channel named was the truth's in 4 of 8 benchmark
    reports (docs/mismatch.md 9.7's thirty-third run, 9.35); the name stays, its channel
    is said to be uncertain."""
    if ev.candidate.group != "equation":
        return []
    return sorted({a.candidate.channel for a in alts
                   if a.candidate.effect == ev.candidate.effect
                   and a.candidate.channel != ev.candidate.channel})  # fmt: skip


def _axes(channel: str) -> set[str]:
    """The axes a channel label names ("x1", "y1<-x1", "acc:x1<-x2", "x1 readout")."""
    return set(re.findall(r"[xy][12]", channel))


#: A two-axis coupling is ambiguous beside a nonlinear or product feature on one of its
#: axes (docs/mismatch.md 9.10).
COUPLING_RIVALS = True


def could_stand_in(alt, cand) -> bool:
    """Can candidate ``alt`` explain what ``cand`` does?  Not when the two are fitted in
    different residual groups (:attr:`Candidate.group`) and share no axis: a displacement
    readout's scale of x2 lives in x2's readout-vs-accelerometer residual, a force on x1
    in the equation residual, and neither can touch the other's data.  At a greedy step
    they are compared only by size, so being within AMBIGUOUS_DBIC there says nothing
    about which is true (f130102: a true readout scale of x2 left ambiguous beside
    unnamed forces on x1, the rivals of the true cubic of x1).  Within one group the
    equation residual's f_B-free combinations mix every axis, so there any alternative
    may stand in."""
    return alt.group == cand.group or shares_axis(alt.channel, cand.channel)


def _rivals(ev, alts, dg: Diagnosis | None = None) -> list[dict]:
    """Why a selected effect's name is not a confident one (empty: it is):

    * near alternatives (within AMBIGUOUS_DBIC) of another name, catalogue or unnamed,
      that could stand in for it (:func:`could_stand_in`);
    * with ``dg``: an unnamed feature selected on the same channel (a linear drift beside
      a curvature, a stiffness drift beside a stiffness step);
    * with ``dg``: excess the final model still leaves located on one of the effect's
      axes in the effect's own residual group (equation residual for forces, the readout
      residual for kinematic effects; :attr:`Diagnosis.locations_after`) -- the best
      catalogue effect left
      significant structure there, so it is at most part of the story (issue 26: a
      confident wrong name is the worst outcome);
    * with ``dg``: a shape misfit (:attr:`Diagnosis.misfits`): the residual on its
      channel needs what the effect's shape lacks (a drift that is not linear);
    * with ``dg``: weak evidence or a stronger effect's remainder (:attr:`Diagnosis.weak`,
      :func:`tmopt.mismatch.diagnose.weak_names`)."""
    # a near alternative that the selection took too, and kept through its backward pass,
    # explains what this one does not: both are in the model, neither stands in for the
    # other (k110087: a cross-talk x1<-y1 and a gain of x2, both true, 5 apart at step 1)
    taken = set() if dg is None else {s.candidate.key for s, _ in dg.selected}
    # an alternative the data still need the effect beside cannot stand in for it either
    # (:func:`tmopt.mismatch.diagnose.needed_in_place`)
    kept = set() if dg is None else dg.not_rivals
    out = [{"name": a.candidate.effect, "channel": a.candidate.channel, "delta_bic": a.dbic,
            **_feature_of(a.candidate)}
           for a in alts if a.candidate.effect != ev.candidate.effect
           and a.candidate.key not in taken
           and (ev.candidate.key, a.candidate.key) not in kept
           and could_stand_in(a.candidate, ev.candidate)]  # fmt: skip
    if dg is None:
        return out
    out += [{"name": f.candidate.effect, "channel": f.candidate.channel, "delta_bic": f.dbic,
             **_feature_of(f.candidate)}
            for f, _ in dg.features if f.candidate.channel == ev.candidate.channel]  # fmt: skip
    # a nonlinear or product force selected on an axis of a two-axis coupling (a
    # cross-talk, a cross-coupling): its lines are partly a linear coupling's, so the
    # coupling may be its remainder (u|u| on x2 beside a cross-talk y2<-x2, k40125; x2*y2
    # beside a cross-talk x2<-y2, k50114)
    mine = _axes(ev.candidate.channel)
    if COUPLING_RIVALS and len(mine) == 2:
        out += [{"name": f.candidate.effect, "channel": f.candidate.channel,
                 "delta_bic": f.dbic, **_feature_of(f.candidate)}
                for f, _ in dg.features
                if f.candidate.fixed.get("feature") in generic.NONLINEAR_KINDS
                and _axes(f.candidate.channel) & mine]  # fmt: skip
    out += [{"name": f"shape misfit (its residual needs {m.get('shape', 'a curvature')}: "
                     "not the effect's shape)", "channel": m["channel"], "delta_bic": None,
             "glr": m["glr"], "p_value": m["p_value"], "checks": m.get("checks", [])}
            for m in dg.misfits if m["key"] == ev.candidate.key]  # fmt: skip
    for w in dg.weak:
        if w["key"] != ev.candidate.key:
            continue
        if w["kind"] == "weak":
            out.append({"name": "no effect (evidence not strong: delta BIC below "
                                f"{cal.AMBIGUOUS_DBIC:g})", "channel": w["channel"],
                        "delta_bic": ev.dbic})  # fmt: skip
        else:
            out.append({"name": f"remainder of {w['of']} (below its model precision, "
                                f"{cal.MODEL_PRECISION:.0%} of its signal)",
                        "channel": w["channel"], "delta_bic": None})  # fmt: skip
    # an explanation beyond physics was taken out: the instrument does something the
    # catalogue cannot hold, and through the loop (every force follows the readouts) on
    # any axis, so no name is more than part of the story (a clipped accelerometer was
    # fitted as a readout scale of 1e5, then as a DAC quantisation; a stuck x2 sensor,
    # once its stiffness drift of 10 s^-2 was out, as a cross-coupling y1<-x1)
    out += [{"name": f"explanation beyond physics taken out ({b['key']})",
             "channel": b["channel"], "delta_bic": None} for b in dg.beyond]  # fmt: skip
    # a measured channel at a rail (an ADC saturating): read as measurements, the fit
    # reads clipped samples through the loop on every axis (a clipped accelerometer was
    # named a DAC quantisation of all axes: k40137, k50136); left out as gaps, the record
    # falls into short pieces that raise names on clean recordings too (docs 9.22).  So
    # either way no name is more than part of it
    out += [{"name": f"saturated {s['channel']} ({s['samples']} samples at its rail)",
             "channel": s["axis"], "delta_bic": None} for s in dg.saturated]  # fmt: skip
    mine = _axes(ev.candidate.channel)
    kin = ev.candidate.group == "kinematic"  # its structure is in the readout residual
    left = [c for c in dg.locations_after.channels
            if _axes(c) & mine and c.endswith(" readout") == kin]  # fmt: skip
    if left:
        out.append({"name": "unexplained structure left", "channel": ", ".join(left),
                    "delta_bic": None})  # fmt: skip
    return out


def _unexplained_at(dg: Diagnosis, rep: dict) -> dict:
    """Where the unexplained part is: the unnamed features' channels, onsets and lines,
    and what the final model still leaves located."""
    loc = {k: list(v) for k, v in rep["locations_unexplained"].items()}
    for f in rep["features"]:
        if f["channel"] not in loc["channels"]:
            loc["channels"].append(f["channel"])
        p = f["parameters"]
        if "t0_s" in p:
            loc["time_s"].append([p["t0_s"], p["t0_s"]])
        if "frequency_hz" in p:
            loc["frequency_hz"].append([p["frequency_hz"], p["frequency_hz"]])
    # a name that is ambiguous with an unnamed shape (a feature within AMBIGUOUS_DBIC, or
    # one its own residual needs: a shape misfit) leaves its channel unexplained
    for a in rep["ambiguous"]:
        if any(r["name"] not in _NEEDS for r in a["rivals"]) and \
                a["channel"] not in loc["channels"]:  # fmt: skip
            loc["channels"].append(a["channel"])
        # a misfit seen with the effect at another placement (a drift on y1 whose curve
        # lives on x2, diagnose._placed_check): there too
        for r in a["rivals"]:
            if r["name"].startswith("shape misfit") and r["channel"] not in loc["channels"]:
                loc["channels"].append(r["channel"])
    # an explanation beyond physics, taken out: its residual channel (the axis's force
    # equation, or the axis's readout for a kinematic one) is unexplained
    for s in dg.saturated:  # a measured channel at a rail: its axis
        if s["axis"] not in loc["channels"]:
            loc["channels"].append(s["axis"])
    for b in dg.beyond:
        suffix = " readout" if b["group"] == "kinematic" else ""
        for a in sorted(_axes(b["channel"])) or [b["channel"]]:
            if a + suffix not in loc["channels"]:
                loc["channels"].append(a + suffix)
    return loc


def _not_identifiable(dg: Diagnosis) -> list[dict]:
    out = [dict(r) for r in dg.not_identifiable]
    for _, (ev, alts) in _events(dg):  # one per event: a glitch's strongest piece
        others = _rivals(ev, alts, dg)
        if others:
            out.append({
                "name": ev.candidate.effect, "channel": ev.candidate.channel,
                "reason": "ambiguous",
                "aliased_with": [f"{a['name']}[{a['channel']}]" for a in others],
                "needs": _NEEDS[ev.candidate.effect],
            })  # fmt: skip
    return out


def _feature_entry(dg: Diagnosis, ev) -> dict:
    """An unnamed feature: what (its words and searched parameters), where, how strong."""
    cand = ev.candidate
    # its fitted size in the final model (a step's height, a readout's timing offset)
    fitted = effect_parameters(dg.after, cand) if dg.after is not None else {}
    return {"feature": cand.fixed.get("feature"), "channel": cand.channel,
            "parameters": {k: v for k, v in cand.fixed.items() if k != "feature"},
            "fitted": {k: {"value": float(v), "sigma": float(s)} for k, (v, s) in fitted.items()},
            "evidence": {"delta_bic": ev.dbic, "glr": ev.glr, "p_holm": ev.p_holm,
                         "trials": cand.trials},
            "description": cand.text}  # fmt: skip


def _fmt_loc(loc: dict) -> str:
    parts = []
    if loc["frequency_hz"]:
        parts.append("f in " + ", ".join(f"[{a:.4g}, {b:.4g}] Hz" for a, b in loc["frequency_hz"]))
    if loc["time_s"]:
        parts.append("t in " + ", ".join(f"[{a:.1f}, {b:.1f}] s" for a, b in loc["time_s"][:8])
                     + (" ..." if len(loc["time_s"]) > 8 else ""))  # fmt: skip
    if loc["channels"]:
        parts.append("channels " + ", ".join(loc["channels"]))
    return "; ".join(parts) or "the whole record"


def conclusion(rep: dict) -> str:
    """One line: what the tool concludes."""
    if rep.get("status") == "cannot_diagnose":
        return rep["reason"]
    if not rep["mismatch_detected"]:
        return "no significant mismatch: the residual is consistent with the noise model"
    words = []
    if rep["effects"]:
        words.append("mismatch explained by " + ", ".join(_named(e) for e in rep["effects"]))
    for a in rep.get("ambiguous", []):
        words.append("ambiguous: " + " or ".join(
            [f"{a['name']} [{a['channel']}]"] + [f"{r['name']} [{r['channel']}]"
                                                 for r in a["rivals"]]))  # fmt: skip
    words += [f["description"] for f in rep.get("features", [])]
    words += [f"unexplained: {s['channel']} saturated ({s['samples']} samples at its rail)"
              for s in _saturated(rep)]  # fmt: skip
    loc = rep["locations_unexplained"]
    if loc["frequency_hz"] or loc["time_s"]:
        words.append("unexplained mismatch at " + _fmt_loc(loc))
    return "; ".join(words)


def _named(entry: dict) -> str:
    """An effect entry in words, with the channels the data barely chose between."""
    alt = entry.get("channel_alternatives") or []
    tail = f" (or {' or '.join(f'[{c}]' for c in alt)}: the channel barely chosen)" if alt else ""
    return f"{entry['name']} [{entry['channel']}]{tail}"


def _saturated(rep: dict) -> list[dict]:
    """The saturated channels the plausibility checks found (``check_saturation``)."""
    for c in rep.get("checks", []):
        if c.get("name") == "saturation":
            return list((c.get("values") or {}).get("saturated", []))
    return []


def _diagnostics(dg: Diagnosis) -> dict:
    """Per-tone transfer (x axes) and witness coherence of the nominal residual."""
    r = dg.before.eq_fit.residual
    out: dict = {"tone_transfer": {}, "witness_coherence": {}}
    for a in (0, 1):
        row = dg.basis[a]
        proj = row @ r / float(row @ row)  # least-squares single-axis disturbance
        tones = dg.data.tones(a)
        if tones:
            out["tone_transfer"][AXES[a]] = tone_transfer(proj, dg.data.x[a], dg.data.fs, tones)
    wit = {f"y{k}": dg.data.x[1 + k] for k in (1, 2)}
    wit.update({f"force_{a}": dg.data.force[i] for i, a in enumerate(AXES)})
    if dg.data.omega is not None:
        wit.update({f"sc_omega_{c}": dg.data.omega[j] for j, c in enumerate("xyz")})
    out["witness_coherence"] = witness_coherence(r[0], wit, dg.data.fs,
                                                 dg.locations.frequency_hz, 0.01)  # fmt: skip
    return out


def _refused_report(dg: Diagnosis) -> dict:
    """A recording the tool cannot speak about: why, and the checks that say so."""
    rep = {
        "schema_version": SCHEMA_VERSION, "source": dg.data.source,
        "status": "cannot_diagnose", "reason": dg.refused,
        "checks": dg.verdict.as_dict()["checks"] if dg.verdict else [],
        "data_used": dict(dg.data.usage),
        "mismatch_detected": None, "unexplained": None,
        "locations": {"frequency_hz": [], "time_s": [], "channels": []},
        "locations_unexplained": {"frequency_hz": [], "time_s": [], "channels": []},
        "effects": [], "ambiguous": [], "features": [], "not_identifiable": [],
        "unexplained_at": {"frequency_hz": [], "time_s": [], "channels": []},
        "notes": list(dg.data.notes),
        "settings": _settings(dg),
    }  # fmt: skip
    if dg.saturated:  # a measured channel at its rail: what is known to be wrong, and where
        rep["mismatch_detected"] = rep["unexplained"] = True
        rep["unexplained_at"]["channels"] = sorted({s["axis"] for s in dg.saturated})
    rep["conclusion"] = conclusion(rep)
    return rep


def _settings(dg: Diagnosis) -> dict:
    """Every field of the diagnosis's :class:`Settings` (``alpha`` as ``family_alpha``,
    tuples as lists): a report says which tool made it, a setting added later included
    (``line_refine`` was missing from stop 63's reports)."""
    out = {}
    for f in fields(dg.settings):
        v = getattr(dg.settings, f.name)
        name = "family_alpha" if f.name == "alpha" else f.name
        out[name] = list(v) if isinstance(v, tuple) else v
    return out


def build_report(dg: Diagnosis) -> dict:
    """The report as a JSON-ready dict (see docs/mismatch-report-schema.md)."""
    if dg.refused is not None:
        return _refused_report(dg)
    before = summary(dg.data, dg.basis, dg.before)
    after = summary(dg.data, dg.basis, dg.after)
    entries = _event_entries(dg)
    rep = {
        "schema_version": SCHEMA_VERSION,
        "source": dg.data.source,
        "status": "diagnosed",
        "reason": None,
        "checks": dg.verdict.as_dict()["checks"] if dg.verdict else [],
        "data_used": dict(dg.data.usage),
        "mismatch_detected": dg.mismatch_detected,
        "unexplained": dg.unexplained,
        "locations": dg.locations.as_dict(),
        "locations_unexplained": dg.locations_after.as_dict(),
        "effects": [e for e in entries if not e["rivals"]],
        "ambiguous": [e for e in entries if e["rivals"]],
        "features": [{**_feature_entry(dg, ev), **_named_alternatives(alts)}
                     for ev, alts in dg.features],  # fmt: skip
        "not_identifiable": _not_identifiable(dg),
        "fit": {"before": before, "after": after},
        "stiffness": {k: _stiff(s) for k, s in (("before", dg.before), ("after", dg.after))},
        "diagnostics": _diagnostics(dg),
        "settings": _settings(dg),
        "notes": list(dg.data.notes),
    }  # fmt: skip
    for e in rep["effects"]:
        del e["rivals"]
    rep["unexplained_at"] = _unexplained_at(dg, rep)
    # the flag says whether anything is left unexplained, wherever ``unexplained_at``
    # puts it (an ambiguous name with an unnamed rival included): one definition
    rep["unexplained"] = dg.unexplained or any(bool(v) for v in rep["unexplained_at"].values())
    rep["conclusion"] = conclusion(rep)
    return rep


def _events(dg: Diagnosis) -> list[tuple[list, tuple]]:
    """Per physical event of the named effects: its pieces and the one reported
    (:func:`tmopt.mismatch.diagnose.event_pieces`)."""
    return event_pieces(dg.effects)


def _event_entries(dg: Diagnosis) -> list[dict]:
    """One entry per physical event: the pieces of one glitch are reported once, as their
    strongest piece with ``pieces`` (their number, onsets and kicks) -- its rivals decide
    whether the name is confident."""
    out = []
    for pieces, (ev, alts) in _events(dg):
        entry = {**_effect_entry(dg, ev, alts), "rivals": _rivals(ev, alts, dg)}
        if len(pieces) > 1:
            kicks = [effect_parameters(dg.after, p.candidate).get("dv", (float("nan"), 0))[0]
                     for p, _ in pieces]  # fmt: skip
            entry["pieces"] = {"n": len(pieces),
                               "t0_s": [p.candidate.fixed["t0_s"] for p, _ in pieces],
                               "dv": kicks}  # fmt: skip
            entry["explanation"] += (f"; the event's shape is not the catalogue template's: "
                                     f"fitted by {len(pieces)} pieces")  # fmt: skip
        out.append(entry)
    return out


def _stiff(state: State) -> dict:
    s = stiffness(state)
    out = {k: s[k]["value"] for k in ("k1xx", "k2xx")}
    out.update({f"{k}_sigma": s[k]["sigma"] for k in ("k1xx", "k2xx")})
    return out


def _clean(obj):
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    return obj


def write_report(dg: Diagnosis, out: str | Path, plots: bool = True) -> dict:
    """Write report.json, report.md and the PNG plots into ``out``; return the report."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rep = _clean(build_report(dg))
    (out / "report.json").write_text(json.dumps(rep, indent=2))
    if rep["status"] == "cannot_diagnose":
        (out / "report.md").write_text(_markdown_refused(rep))
        return rep
    figs = _plots(dg, rep, out) if plots else []
    (out / "report.md").write_text(_markdown(rep, figs))
    return rep


# -------------------------------------------------------------------------- markdown


def _num(v) -> str:
    return "—" if v is None else (f"{v:.4g}" if isinstance(v, float) else str(v))


def _markdown_refused(rep: dict) -> str:
    lines = [f"# Mismatch report: {rep['source']}", "", f"**{rep['conclusion']}**", "",
             "## Checks of the closed loop's own consistency", ""]  # fmt: skip
    for c in rep["checks"]:
        lines.append(f"- {c['name']}: {c['status']} -- {c['detail']}")
    if rep["notes"]:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in rep["notes"]]
    return "\n".join(lines) + "\n"


def _data_line(rep: dict) -> str:
    u = rep.get("data_used") or {}
    if not u:
        return ""
    return (f"Data used: {u.get('samples_used')} of {u.get('samples_recorded')} samples "
            f"({100 * u.get('fraction_used', 1.0):.1f} %) in {u.get('segments_used')} gap-free "
            f"segment(s); accelerometer convention {u.get('acc_convention', 'held')}"
            + (f", half-step term {u['kinematic_halfstep']:+.4g} (Euler steps)"
               if u.get("kinematic_halfstep") else "")
            + (f", curvature term {u['kinematic_curvature']:.4g} (an integrating readout)"
               if u.get("kinematic_curvature") else "") + ".")  # fmt: skip


def _markdown(rep: dict, figs: list[str]) -> str:
    fb, fa = rep["fit"]["before"], rep["fit"]["after"]
    sb, sa = rep["stiffness"]["before"], rep["stiffness"]["after"]
    lines = [f"# Mismatch report: {rep['source']}", "", f"**{rep['conclusion']}**", "",
             _data_line(rep), ""]  # fmt: skip
    lines += ["## Where (nominal model's residual)", "", _fmt_loc(rep["locations"]), ""]
    lines += ["## Effects selected", ""]
    if rep["effects"]:
        lines += ["| effect | channel | parameters | ΔBIC | p (Holm) | why |",
                  "|---|---|---|---|---|---|"]  # fmt: skip
        for e in rep["effects"]:
            unc = e["uncertainties"]
            par = ", ".join(f"{k} = {_num(v)}" + (f" ± {_num(unc[k])}" if k in unc else "")
                            for k, v in e["parameters"].items() if not isinstance(v, list))
            ev = e["evidence"]
            lines.append(f"| {e['name']} | {e['channel']} | {par} | {_num(ev['delta_bic'])} | "
                         f"{_num(ev['p_holm'])} | {e['explanation']} |")  # fmt: skip
    else:
        lines.append("None passed the calibrated threshold.")
    lines += ["", "## Fit before and after", "", "| | before | after |", "|---|---|---|"]
    for k in ("residual_rms", "bic", "whiteness_p", "output_error_rms", "kinematic_rms"):
        lines.append(f"| {k} | {_num(fb[k])} | {_num(fa[k])} |")
    for k in ("k1xx", "k2xx"):
        lines.append(f"| {k} [s^-2] | {_num(sb[k])} ± {_num(sb[k + '_sigma'])} | "
                     f"{_num(sa[k])} ± {_num(sa[k + '_sigma'])} |")  # fmt: skip
    lines += ["", "## Not identifiable with this excitation", ""]
    for r in rep["not_identifiable"]:
        extra = f" (with {r['aliased_with']})" if r.get("aliased_with") else ""
        lines.append(f"- {r['name']} [{r['channel']}]: {r['reason']}{extra}; needs {r['needs']}")
    if not rep["not_identifiable"]:
        lines.append("- (none)")
    tt = rep["diagnostics"]["tone_transfer"]
    if tt:
        lines += ["", "## Per-tone transfer of the residual to the motion", "",
                  "| axis | f [Hz] | abs(T) [s^-2] | phase [deg] |",
                  "|---|---|---|---|"]  # fmt: skip
        for ax, rows in tt.items():
            lines += [f"| {ax} | {r['frequency_hz']:.4g} | {r['magnitude']:.3g} | "
                      f"{r['phase_deg']:.1f} |" for r in rows]  # fmt: skip
    lines += ["", "## Plots", ""] + [f"![{f}]({f})" for f in figs]
    if rep["notes"]:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in rep["notes"]]
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- plots


def _plots(dg: Diagnosis, rep: dict, out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = dg.data
    before, after = dg.before.eq_fit.residual, dg.after.eq_fit.residual
    names = []
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for r, lab in ((before, "before"), (after, "after")):
        f, p = _psd(r[0], d.fs)
        ax.loglog(f[1:], np.sqrt(p[1:]), label=f"K-combination residual, {lab}", lw=0.8)
    noise = dg.after.eq_noise
    if noise.kind == "smoothed":
        fm = np.geomspace(1.0 / (d.n * d.dt), d.fs / 2, 200)
        ax.loglog(fm, noise.asd(fm)[0], color="k", ls="--", lw=0.8,
                  label="noise model (estimated, coloured)")  # fmt: skip
    else:
        sig = math.sqrt(noise.cov[0, 0])
        ax.axhline(sig * math.sqrt(2 / d.fs), color="k", ls="--", lw=0.8,
                   label="noise floor (white)")  # fmt: skip
    for lo, hi in rep["locations"]["frequency_hz"]:
        ax.axvspan(max(lo, 1 / (d.n * d.dt)), hi, color="r", alpha=0.15)
    ax.set(xlabel="frequency [Hz]", ylabel="ASD [m s^-2 / sqrt(Hz)]", title="Residual spectrum")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "residual_psd.png", dpi=110)
    plt.close(fig)
    names.append("residual_psd.png")
    fig, axes = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for a, (r, lab) in zip(axes, ((before, "before"), (after, "after"))):
        a.plot(d.time, r[0], lw=0.4, label="K-combination")
        a.plot(d.time, r[1], lw=0.4, label="second f_B-free combination")
        for t0, t1 in rep["locations"]["time_s"]:
            a.axvspan(t0, t1, color="r", alpha=0.15)
        a.set(ylabel=f"residual {lab} [m s^-2]")
        a.legend(fontsize=7, loc="upper right")
    axes[-1].set(xlabel="time [s]")
    fig.tight_layout()
    fig.savefig(out / "residual_time.png", dpi=110)
    plt.close(fig)
    names.append("residual_time.png")
    return names


def _psd(v: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy import signal

    return signal.welch(v, fs=fs, nperseg=min(v.size, 4096))


# ------------------------------------------------------------ for the design tool


def _feature_of(cand) -> dict:
    """``{"feature": kind}`` of an unnamed feature (which shape, so that a rival can be
    rebuilt on another run: tmopt.design), else nothing."""
    kind = None if cand.effect in _NEEDS else cand.fixed.get("feature")  # not catalogue
    return {"feature": kind} if kind is not None else {}


def design_entries(dg: Diagnosis) -> dict:
    """What the design tool reads of a report, without building the whole report: the
    ``ambiguous`` entries (effect entries with ``rivals``) and, per selected unnamed
    feature, its ``feature``, ``channel`` and named ``alternatives``."""
    if dg.refused is not None:
        return {"ambiguous": [], "features": []}
    return {"ambiguous": [e for e in _event_entries(dg) if e["rivals"]],
            "features": [{"feature": ev.candidate.fixed.get("feature"),
                          "channel": ev.candidate.channel, **_named_alternatives(alts)}
                         for ev, alts in dg.features]}  # fmt: skip


def _named_alternatives(alts) -> dict:
    """``{"alternatives": [...]}``: the catalogue names within the ambiguity band of a
    selected unnamed feature (a true cubic selected as ``x|x|``), else nothing."""
    named = [{"name": a.candidate.effect, "channel": a.candidate.channel, "delta_bic": a.dbic}
             for a in alts if a.candidate.effect in _NEEDS]  # fmt: skip
    return {"alternatives": named} if named else {}
