"""What the design tool writes: ``next_excitation.json``, ``design.md`` (with the physical
reasons in words) and ``next_excitation.png`` (the proposed motion, the predicted
standard errors before/after)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from tmopt.design.plan import Plan
from tmopt.files import atomic_write_text
from tmopt.mismatch.effects import EFFECTS
from tmopt.mismatch.effects.cubic_stiffness import CubicStiffness
from tmopt.mismatch.effects.readout_scale import ReadoutScale
from tmopt.mismatch.effects.sensing_cross_talk import SensingCrossTalk
from tmopt.mismatch.effects.stiffness_cross_coupling import StiffnessCrossCoupling
from tmopt.mismatch.effects.stiffness_drift import StiffnessDrift
from tmopt.physics.recording import AXES

__all__ = ["SCHEMA_VERSION", "build", "write", "explain"]

SCHEMA_VERSION = 1
NOMINAL_REPORTED = ("k1xx", "k2xx", "k1yy", "k2yy")


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def motion(plan: Plan) -> dict[str, list[dict]]:
    """The design's tones per axis: amplitude [m], period [s], frequency [Hz], phase."""
    body = plan.spec.partition(":")[2].split(";")
    out = {}
    for a, group in zip(AXES, body):
        comps = []
        for c in (group.split(",") if group.strip() else []):
            amp, per, ph = (float(v) for v in c.split("@"))
            comps.append({"amplitude_m": amp, "period_s": per, "frequency_hz": 1 / per,
                          "phase_rad": ph})  # fmt: skip
        out[a] = comps
    return out


def build(plan: Plan, source: str = "", notes: list[str] | None = None) -> dict:
    """``next_excitation.json`` as a dict (see docs/design.md)."""
    pb = plan.problem
    targets = []
    for t in pb.targets:
        b, a = plan.before.se[t.key], plan.after.se[t.key]
        targets.append({
            "effect": t.effect, "channel": t.channel, "reason": t.reason,
            "aliased_with": t.aliased_with, "plausible": t.plausible,
            "se_before": _finite(b), "se_after": _finite(a),
            "detectable_before": bool(pb.z * plan.before.judged(t.key) <= t.plausible),
            "detectable_after": bool(pb.z * plan.after.judged(t.key) <= t.plausible),
            "correlation_before": _corr(plan.before, t.key),
            "correlation_after": _corr(plan.after, t.key),
        })  # fmt: skip
        if t.rivals:  # an ambiguous name: its rivals and the expected delta-BIC gap
            sb, sa = plan.before.judged(t.key), plan.after.judged(t.key)
            targets[-1].update({"rivals": [r.key for r in t.rivals],
                                "se_selection_before": _finite(sb),
                                "se_selection_after": _finite(sa),
                                "delta_bic_gap_before": _gap(t.plausible, sb),
                                "delta_bic_gap_after": _gap(t.plausible, sa)})  # fmt: skip
    return {
        "schema_version": SCHEMA_VERSION,
        "source": source,
        "excitation": plan.spec,
        "duration_s": plan.duration,
        "sample_rate_hz": pb.settings.sample_rate,
        "simulate": (f"python -m tmopt.simulate --excitation '{plan.spec}' --duration "
                     f"{plan.duration:g} --sample-rate {pb.settings.sample_rate:g}"),
        "motion": motion(plan),
        "feasible": plan.feasible,
        "all_detectable": plan.all_detectable,
        "detection_threshold_z": pb.z,
        "stiffness_se": {k: {"before": _finite(plan.before.se[k]),
                             "after": _finite(plan.after.se[k])} for k in NOMINAL_REPORTED},
        "targets": targets,
        "constraints": dict(zip(pb.constraint_names, map(float, plan.constraints))),
        "objectives": dict(zip(pb.physical_names, map(float, plan.objectives))),
        "free_axes": list(pb.space.axes),
        "designs_evaluated": plan.n_evaluated,
        "model": {"stiffness": list(pb.settings.stiffness), "controller": pb.settings.controller},
        "notes": list(notes or []),
    }  # fmt: skip


def _gap(size: float, se: float) -> float | None:
    """Expected delta-BIC gap between an ambiguous name of coefficient ``size`` (if it is
    the truth) and its rivals: ``(size / se)^2`` with ``se`` its standard error with the
    rivals profiled at the diagnosis' selection step (docs/design.md, "Ambiguous
    names")."""
    return _finite((size / se) ** 2) if se > 0 else None


def _corr(pred, key: str) -> dict:
    c, name = pred.correlation.get(key, (0.0, ""))
    return {"abs": float(c), "with": name or None}


# ------------------------------------------------------------------ the words


def _tones(comps: list[dict]) -> str:
    return ", ".join(f"{c['amplitude_m'] * 1e6:.3g} um at 1/{c['period_s']:.0f} Hz"
                     for c in comps)  # fmt: skip


def _moves(rep: dict, axis: str) -> str:
    comps = rep["motion"].get(axis, [])
    return f"moves {axis} ({_tones(comps)})" if comps else f"holds {axis} still"


def explain(rep: dict) -> list[str]:
    """One paragraph per target: what the new motion does physically to reveal it."""
    out = []
    for t in rep["targets"]:
        e, ch = t["effect"], t["channel"]
        why = t["reason"] + (f" with {t['aliased_with']}" if t["aliased_with"] else "")
        tail = (f" Predicted standard error {_num(t['se_before'])} -> {_num(t['se_after'])} "
                f"(plausible size {t['plausible']:g}; detectable "
                f"{'yes' if t['detectable_after'] else 'no'}).")  # fmt: skip
        if t.get("rivals"):
            cb, ca = t["correlation_before"], t["correlation_after"]
            tail += (f" Separated from {' and '.join(t['rivals'])}: |correlation| "
                     f"{cb['abs']:.3f} -> {ca['abs']:.3f} (largest, with {ca['with']}); "
                     f"expected delta-BIC gap if it is the truth "
                     f"{_num(t['delta_bic_gap_before'])} -> {_num(t['delta_bic_gap_after'])} "
                     "(ambiguous below 6).")  # fmt: skip
        out.append(f"- **{e} [{ch}]** (was {why}): " + _physics(rep, e, ch) + tail)
    return out


def _physics(rep: dict, effect: str, channel: str) -> str:
    """The words for one target; the effect is recognised by its class (its name has one
    home, its module)."""
    kind, _, ch = channel.rpartition(":")
    if "<-" in ch:
        dst, src = ch.split("<-")
    else:
        dst = src = ch
    cls = type(EFFECTS[effect]) if effect in EFFECTS else None
    if cls is StiffnessCrossCoupling:
        return (f"the design {_moves(rep, src)}, so that the {dst}<-{src} coupling shows as a "
                f"force in {dst} that follows {src}'s tones, which differ from {dst}'s own, "
                f"so the k_{dst}{src} column is no longer a copy of k_{dst[0]}{dst} x.")
    if cls is CubicStiffness:
        return (f"the design {_moves(rep, ch)} with amplitudes near Eq. 20's limit: "
                f"k3 {ch}^3 grows like A^3 and puts a line at three times each tone "
                f"(and at the tones' intermodulation), which the linear k {ch} cannot fit.")
    if cls is StiffnessDrift:
        return (f"the design {_moves(rep, ch)} for the whole run: a drifting stiffness then "
                f"shows as a force t * {ch} whose amplitude grows through the run, "
                f"separable from the constant k {ch} (it is invisible while {ch} is still).")
    if cls is SensingCrossTalk:
        return (f"the design {_moves(rep, src)}: the {kind or 'displacement'} readout of "
                f"{dst} then sees {src}'s tones without any matching acceleration of {dst} "
                f"(the ZOH kinematics x'' = a breaks at {src}'s frequencies).")
    if cls is ReadoutScale:
        return (f"the design {_moves(rep, ch)}: the {kind or 'displacement'} readout's scale "
                f"error (1+e) then breaks the kinematic identity x'' = a on {ch} in "
                f"proportion to {ch}'s acceleration (in Eq. 10 alone it is aliased with k).")
    return f"the design {_moves(rep, ch)}."


def _num(v) -> str:
    return "inf" if v is None else f"{v:.3g}"


def markdown(rep: dict, figure: str | None) -> str:
    lines = [f"# Next excitation for {rep['source'] or 'the recording'}", "",
             f"**Excitation** (`python -m tmopt.simulate` syntax, axes x1;x2;y1;y2): "
             f"`{rep['excitation']}` for {rep['duration_s']:g} s at "
             f"{rep['sample_rate_hz']:g} Hz.", "", f"Run it: `{rep['simulate']}`", ""]
    if not rep["feasible"]:
        lines += ["**No design met Eq. 20 on every axis; this is the least violating.**", ""]
    elif not rep["all_detectable"]:
        lines += ["**No feasible design makes every target detectable; the closest shown.**",
                  ""]  # fmt: skip
    lines += ["## What the new motion does", ""]
    for a in AXES:
        lines.append(f"- {a}: " + (_tones(rep["motion"][a]) or "held at zero"))
    lines += ["", "## Why, target by target", ""] + explain(rep)
    lines += ["", "## Predicted standard errors (information matrix at the recording's noise)",
              "", "| parameter | before | after | |corr| with nominal before -> after |",
              "|---|---|---|---|"]  # fmt: skip
    for k, v in rep["stiffness_se"].items():
        lines.append(f"| {k} [s^-2] | {_num(v['before'])} | {_num(v['after'])} | |")
    for t in rep["targets"]:
        cb, ca = t["correlation_before"], t["correlation_after"]
        lines.append(f"| {t['effect']}[{t['channel']}] | {_num(t['se_before'])} | "
                     f"{_num(t['se_after'])} | {cb['abs']:.3f} ({cb['with']}) -> "
                     f"{ca['abs']:.3f} ({ca['with']}) |")  # fmt: skip
    lines += ["", "## Eq. 20 on the realised motion (value / limit - 1, feasible <= 0)", ""]
    lines += [f"- {k}: {v:+.3f}" for k, v in rep["constraints"].items()]
    if figure:
        lines += ["", f"![proposed motion]({figure})"]
    for n in rep["notes"]:
        lines += ["", f"Note: {n}"]
    return "\n".join(lines) + "\n"


def plot(plan: Plan, rep: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = plan.run
    t = run.time
    fig, axes = plt.subplots(3, 1, figsize=(9, 9))
    for k, a in enumerate(AXES[:2]):
        axes[0].plot(t, run.channels[k, 0] * 1e6, label=f"{a} realised")
    axes[0].set_ylabel("sensitive axes [um]")
    axes[0].legend(loc="upper right", fontsize=8)
    for k, a in enumerate(AXES[2:], start=2):
        axes[1].plot(t, run.channels[k, 0] * 1e6, label=f"{a} realised")
    axes[1].set_ylabel("non-sensitive axes [um]")
    axes[1].set_xlabel("time [s]")
    axes[1].legend(loc="upper right", fontsize=8)
    axes[0].set_title(f"proposed motion ({rep['duration_s']:g} s, noise-free closed loop)")
    names = [f"{x['effect']}\n[{x['channel']}]" for x in rep["targets"]]
    # the standard error each target is judged by (an ambiguous name's at the selection
    # step), so a bar below 1 is what ``detectable_*`` says
    ratio_b, ratio_a = ([(x.get(f"se_selection_{when}") or x[f"se_{when}"] or np.inf)
                         * rep["detection_threshold_z"] / x["plausible"]
                         for x in rep["targets"]] for when in ("before", "after"))  # fmt: skip
    pos = np.arange(len(names))
    cap = 1e12
    axes[2].bar(pos - 0.2, np.minimum(ratio_b, cap), 0.4, label="recorded excitation")
    axes[2].bar(pos + 0.2, np.minimum(ratio_a, cap), 0.4, label="proposed")
    axes[2].axhline(1.0, color="k", ls="--", lw=0.8, label="detectable below")
    axes[2].set_yscale("log")
    # matplotlib's log limits start at the smallest bar's top, which hid a lone target's
    # "proposed" bar (z sigma / plausible 0.017) under the axis: keep a decade below it
    shown = np.minimum(np.r_[ratio_b, ratio_a, 1.0], cap)
    axes[2].set_ylim(shown[shown > 0].min() / 10, shown.max() * 3)
    axes[2].set_xlim(-0.7, len(names) - 0.3)
    axes[2].set_xticks(pos, names, fontsize=6, rotation=60, ha="right")
    axes[2].set_ylabel("z sigma / plausible (bars capped at 1e12)")
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write(plan: Plan, out: str | Path, source: str = "", notes: list[str] | None = None,
          plots: bool = True) -> dict:  # fmt: skip
    """Write the three outputs into ``out``; return the JSON dict."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rep = build(plan, source, notes)
    fig = None
    if plots:
        fig = "next_excitation.png"
        plot(plan, rep, out / fig)
    atomic_write_text(out / "next_excitation.json", json.dumps(rep, indent=2) + "\n")
    atomic_write_text(out / "design.md", markdown(rep, fig))
    return rep
