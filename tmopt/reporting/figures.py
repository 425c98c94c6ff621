"""Figures of a sweep: paper Figs. 8-10 for the stiffness problem, IGD/HV boxes for suites.

Fig. 10 needs time series that runs do not store (only the chosen design's numbers are
in metrics.json), so the chosen design is simulated again with the run's own problem
configuration and noise seed. The simulator is deterministic for a given design and
seed, so this reproduces the run's numbers exactly; :func:`fig10` checks that it does
and says so in the caption.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tmopt.reporting.paper import display_name  # noqa: E402
from tmopt.reporting.runs import RunRecord  # noqa: E402
from tmopt.reporting.stats import finite  # noqa: E402
from tmopt.reporting.tables import label  # noqa: E402
from tmopt.run.plots import log_if_spanning_decades, note_nothing_to_draw  # noqa: E402

SCHEMES = ("A", "B", "C")


# ---- Figs. 8 and 9 --------------------------------------------------------------------
def _series(rows: list[dict], scheme: str) -> dict[str, list[dict]]:
    """Summary rows of one scheme, split by everything but scheme and k, sorted by k."""
    out: dict[str, list[dict]] = {}
    for row in rows:
        s = row["setting"]
        if s.get("scheme") != scheme:
            continue
        name = label(s, hide=("scheme", "problem.n_freq", "problem")) or "runs"
        out.setdefault(name, []).append(row)
    for series in out.values():
        series.sort(key=lambda r: int(r["setting"]["problem.n_freq"]))
    # a setting run at one k is a point, not a curve against k: collected beside a sweep
    # over k (Table 3's ten algorithms at k = 3), it would bury the curves under a legend
    # entry each; table3.md is its view
    return {n: s for n, s in out.items() if len({r["setting"]["problem.n_freq"] for r in s}) > 1}


def _no_curve(rows: list[dict], scheme: str) -> str:
    """What an empty panel of ``scheme`` says: no runs, or runs at one k per setting."""
    ks = sorted({int(r["setting"]["problem.n_freq"]) for r in rows
                 if r["setting"].get("scheme") == scheme})  # fmt: skip
    if not ks:
        return f"no runs of scheme {scheme}"
    return (f"scheme {scheme}: each setting at one k ({', '.join(map(str, ks))}),\n"
            "no curve against k (table3.md lists them)")


def _quartiles(row: dict, key: str) -> tuple[float, float, float, np.ndarray]:
    """Median, lower and upper quartile of one setting's per-run values (NaN if none)."""
    v = np.asarray([x for x in row["values"].get(key, []) if x is not None], float)
    v = v[np.isfinite(v)]
    if not len(v):
        return math.nan, math.nan, math.nan, v
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return float(med), float(q1), float(q3), v


def _median_iqr(ax, rows: list[dict], key: str, shift: float = 0.0, runs: bool = True,
                **kw) -> None:
    """Median against k with the interquartile range as bars and every run as a dot.

    Held-out M and accuracies are skewed (one stuck run multiplies a mean and its std,
    docs/results.md, Figs. 8-9), so the figure shows what a typical run gets and how far
    runs spread, not mean ± std. ``shift`` moves a series sideways so that series at the
    same k do not hide each other. A black x: some run's chosen design is infeasible.
    ``runs=False`` (a secondary series, e.g. the search draw): the line and bars only.
    """
    k = np.array([int(r["setting"]["problem.n_freq"]) for r in rows], float) + shift
    q = [_quartiles(r, key) for r in rows]
    med = np.array([x[0] for x in q])
    err = np.array([[m - lo, hi - m] for m, lo, hi, _ in q]).T.reshape(2, -1)
    line = ax.errorbar(k, med, yerr=np.nan_to_num(err), capsize=3, **{"marker": "o", **kw})
    if not runs:  # a secondary series: its line only
        return
    for ki, (*_, v) in zip(k, q):
        ax.plot(np.full(len(v), ki), v, ".", color=line.lines[0].get_color(), alpha=0.35,
                ms=4, label="_runs")
    bad = [(ki, m) for ki, m, r in zip(k, med, rows) if r["chosen_feasible"][0] < 1]
    if bad:
        ax.plot(*zip(*bad), "kx", ms=9, label="_infeasible")


def _shifts(n: int, width: float = 0.24) -> list[float]:
    """Sideways offsets of n series at one k, spread over ``width``."""
    return [0.0] if n < 2 else list(np.linspace(-width / 2, width / 2, n))


def fig8(rows: list[dict], path: Path) -> None:
    """Per scheme: convergence time (left axis) and accuracy (right, log) against k."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for ax, scheme in zip(axes, SCHEMES):
        ax2 = ax.twinx()
        series_of_scheme = _series(rows, scheme)
        ax.set_title(f"({'abc'[SCHEMES.index(scheme)]}) Scheme {scheme}")
        if not series_of_scheme:
            note_nothing_to_draw(ax, _no_curve(rows, scheme))
            ax2.set_yticks([])
            continue
        shifts = _shifts(len(series_of_scheme))
        for i, (name, series) in enumerate(series_of_scheme.items()):
            _median_iqr(ax, series, "heldout_convergence_time", shifts[i], color=f"C{i}",
                        label=f"{name}: time")
            _median_iqr(ax2, series, "heldout_convergence_accuracy", shifts[i], runs=False,
                        color=f"C{i}", ls="--", marker="s", mfc="white",
                        label=f"{name}: accuracy")
        ax.set_xlabel("number of frequencies k")
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.set_ylabel("convergence time TM1 (s), solid")
        ax2.set_ylabel("convergence accuracy TM1 (s$^{-2}$), dashed")
        _log_if_positive(ax2)
        _merged_legend(ax, ax2)
    fig.suptitle("Fig. 8: chosen design (Eq. 21) per configuration on held-out noise seeds: "
                 "median and interquartile range over runs, dots: single runs' times\n"
                 "(x: the chosen design of some run is infeasible)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def fig9(rows: list[dict], path: Path, floor_M: float | None = None) -> None:
    """M (Eq. 29) of the chosen design against k: one panel per scheme, one line per
    setting (held-out solid, the search draw dotted), the physical floor ``floor_M``
    (docs/noise.md) as a grey line."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), sharey=True)
    drawn = []
    by_scheme = {scheme: _series(rows, scheme) for scheme in SCHEMES}
    for ax, scheme in zip(axes, SCHEMES):
        series_of_scheme = by_scheme[scheme]
        ax.set_title(f"({'abc'[SCHEMES.index(scheme)]}) Scheme {scheme}")
        ax.set_xlabel("number of frequencies k")
        if not series_of_scheme:
            note_nothing_to_draw(ax, _no_curve(rows, scheme) if rows
                                 else "no stiffness runs with a scheme and k to draw")
            continue
        shifts = _shifts(len(series_of_scheme))
        for i, (name, series) in enumerate(series_of_scheme.items()):
            _median_iqr(ax, series, "heldout_M", shifts[i], color=f"C{i}",
                        label=f"{name}, held-out")
            _median_iqr(ax, series, "M_TM1", shifts[i], runs=False, color=f"C{i}", ls=":",
                        marker=".", alpha=0.6, label=f"{name}, search draw")
        if floor_M is not None and math.isfinite(floor_M):
            ax.axhline(floor_M, color="0.4", ls="--", lw=1,
                       label=f"physical floor M = {floor_M:.2f}")
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.legend(fontsize=7)
        drawn.append(ax)
    axes[0].set_ylabel("M of TM1 [-] (Eq. 29, lower is better)")
    _log_if_positive(axes[0], *drawn)  # shared y; a stuck run lies 10-70x above the rest
    fig.suptitle("Fig. 9: M per configuration on held-out noise seeds: median and "
                 "interquartile range over runs, dots: single runs; dotted: the search "
                 "draw's median\n(x: the chosen design of some run is infeasible)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _log_if_positive(ax, *others) -> None:
    """Log y on ``ax`` when every finite value drawn on it and ``others`` is positive."""
    values = np.concatenate([np.asarray(ln.get_ydata(), float) for a in (ax, *others)
                             for ln in a.get_lines()] or [np.zeros(0)])
    values = values[np.isfinite(values)]
    if len(values) and np.all(values > 0):
        ax.set_yscale("log")


def _merged_legend(ax, ax2) -> None:
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    if h1 or h2:
        ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="best")


# ---- Fig. 10 ------------------------------------------------------------------------
def fig10(run: RunRecord, png: Path, csv_path: Path, why: str) -> str:
    """Re-simulate the run's chosen design; plot TM1/TM2 motion and the k1xx curves on
    the run's held-out noise seeds (their spread; the search-draw curve dashed).

    Returns the caption (also written under the figure).
    """
    from tmopt.problems.stiffness import StiffnessProblem

    node = run.config["problem"]  # resolved config.yaml: constructor arguments + _target_
    problem = StiffnessProblem(**{k: v for k, v in node.items() if not k.startswith("_")})
    x = np.asarray(run.metrics["chosen"]["X"], dtype=float)
    row = (run.metrics.get("chosen") or {}).get("index")
    seeds = _row_seeds(run, row)
    res = problem.simulate_designs(x[None, :], record="full",
                                   seed=seeds[0] if len(seeds) else problem.noise_seed)
    check = problem.identification_report(x, seeds=seeds if len(seeds) else None)
    held = run.metrics.get("heldout") or {}
    n_held = int(held.get("n_seeds") or problem.n_heldout)
    curves = problem.heldout_report(x[None, :], n_held) if n_held else None
    spread = None
    if curves is not None:
        ref1, ref2 = problem.references(x[None, :])
        from tmopt.physics.simulator import simulate

        rep = simulate(ref1.take(np.zeros(n_held, int)), ref2.take(np.zeros(n_held, int)),
                       problem.config, seed=curves["seeds"])
        spread = rep.theta_hat[:, :, 0]
    d = res.design(0)
    from tmopt.physics.floor import stiffness_floor

    floor_sd = np.sqrt(stiffness_floor(problem.config, 0, problem.constraint_mode).variance())
    _fig10_plot(d, res.config.theta_true[0], png, f"Fig. 10: {why} (re-simulated)", spread,
                floor_sd)
    _fig10_csv(d, csv_path, spread)
    text = _fig10_caption(run, check, why) + " " + _tracking_text(d)
    if curves is not None:
        m = curves["M_TM1"][0]
        text += (f" On {n_held} held-out noise seeds: M = {m.mean():.3g} ± {m.std(ddof=1):.2g}"
                 f" (median {np.median(m):.3g}, range {m.min():.3g}-{m.max():.3g}), "
                 f"convergence time {curves['convergence_time_TM1'][0].mean():.1f} ± "
                 f"{curves['convergence_time_TM1'][0].std(ddof=1):.1f} s, final accuracy "
                 f"{curves['final_accuracy_TM1'][0].mean():.3g} s^-2 (mean |error|); panel "
                 "(c) shows every held-out curve (grey), their 10-90 % band and median.")
    return text


def _row_seeds(run: RunRecord, row) -> np.ndarray:
    """The noise seeds that scored archive row ``row`` of the run (empty when unknown)."""
    if row is None:
        return np.zeros(0, np.int64)
    try:
        from tmopt.evaluation.archive import read_archive

        seeds = read_archive(run.path / "archive.h5").noise_seeds[int(row)]
    except Exception:  # noqa: BLE001 - no archive: the problem's own seeds are used
        return np.zeros(0, np.int64)
    return seeds[seeds >= 0]


#: Times after which tracking is judged: the paper's "effective control within 3 min"
#: (Fig. 10 text) and the simulator's steady-state window (SimulationConfig.steady_after).
SETTLED_AFTER_S = (180.0, 300.0)


def _tracking_text(d: dict) -> str:
    """Max |reference - true x| over the run and after 3 and 5 min, TM1 and TM2."""
    parts = []
    for k in ("1", "2"):
        err = np.abs(d[f"ref_x{k}"] - d[f"x{k}_true"])
        late = ", ".join(f"after {t:.0f} s {err[d['time'] >= t].max():.2e} m"
                         for t in SETTLED_AFTER_S)
        parts.append(f"TM{k} max tracking error {err.max():.2e} m, {late}")
        parts.append(f"max |x{k}| {np.abs(d[f'x{k}_true']).max() * 1e3:.3f} mm")
    return "; ".join(parts) + "."


def _fig10_plot(d: dict, truth: float, path: Path, title: str,
                spread: np.ndarray | None = None, floor_sd: np.ndarray | None = None) -> None:
    """(a, b) the motions; (c) the k1xx curves; (d) with held-out curves: their rms error
    against time beside the physical floor's (``floor_sd``)."""
    import textwrap

    rows = 4 if spread is not None else 3
    fig, axes = plt.subplots(rows, 1, figsize=(8, 2.9 * rows + 0.4), sharex=True)
    for ax, k in zip(axes[:2], ("1", "2")):
        ax.plot(d["time"], d[f"ref_x{k}"], "k--", lw=1, label="reference")
        ax.plot(d["time"], d[f"x{k}_true"], "C0", lw=0.8, label=f"x{k} (controlled)")
        ax.set_ylabel(f"TM{k} sensitive axis x [m]")
        ax.legend(loc="upper right")
        ax.set_title(f"({'ab'[int(k) - 1]}) TM{k}: reference and controlled displacement")
    ax = axes[2]
    if spread is not None:
        for curve in spread:
            ax.plot(d["time"], curve, color="0.75", lw=0.4)
        lo, mid, hi = np.percentile(spread, [10, 50, 90], axis=0)
        ax.fill_between(d["time"], lo, hi, color="C1", alpha=0.35,
                        label=f"10-90 % over {len(spread)} held-out seeds")
        ax.plot(d["time"], mid, "C1", lw=1.0, label="held-out median")
        ax.plot(d["time"], d["theta_hat"][:, 0], "C0--", lw=0.8, label="search draw (RLS)")
    else:
        ax.plot(d["time"], d["theta_hat"][:, 0], "C0", lw=0.8, label="k1xx estimate (RLS)")
    ax.axhline(truth, color="k", ls="--", lw=1, label="truth")
    ax.set_ylim(truth - 0.2 * abs(truth), truth + 0.2 * abs(truth))
    ax.set_ylabel("k1xx [s$^{-2}$]")
    ax.set_title("(c) identification curve of TM1")
    ax.legend(loc="upper right", fontsize=8)
    if spread is not None:
        ax = axes[3]
        rms = np.sqrt(np.mean((spread - truth) ** 2, axis=0))
        ax.semilogy(d["time"], rms, "C1", lw=1.0, label="rms error over the held-out seeds")
        if floor_sd is not None:
            ax.semilogy(d["time"], floor_sd, "k", lw=1.0,
                        label="physical floor (rms, any admissible motion)")
        ax.set_ylim(max(1e-12, 0.3 * np.min(rms[len(rms) // 10:])), 10 * abs(truth))
        ax.set_ylabel("|k1xx error| rms [s$^{-2}$]")
        ax.set_title("(d) held-out error against the floor (docs/noise.md)")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("\n".join(textwrap.wrap(title, 95)), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _fig10_csv(d: dict, path: Path, spread: np.ndarray | None = None) -> None:
    """The time series at 1 Hz (every 10th sample at 10 Hz), enough to redraw the figure."""
    from tmopt.files import atomic_write_text

    step = max(1, int(round(1.0 / max(np.diff(d["time"][:2]).item(), 1e-9))))
    cols = {"time_s": d["time"], "ref_x1_m": d["ref_x1"], "x1_m": d["x1_true"],
            "ref_x2_m": d["ref_x2"], "x2_m": d["x2_true"], "k1xx_hat": d["theta_hat"][:, 0]}
    if spread is not None:
        for q, v in zip(("p10", "p50", "p90"), np.percentile(spread, [10, 50, 90], axis=0)):
            cols[f"k1xx_heldout_{q}"] = v
    lines = [",".join(cols)]
    for i in range(0, len(d["time"]), step):
        lines.append(",".join(repr(float(v[i])) for v in cols.values()))
    atomic_write_text(path, "\n".join(lines) + "\n")


def _fig10_caption(run: RunRecord, check: dict, why: str) -> str:
    ident = run.identification
    stored, again = ident.get("M_TM1"), check.get("M_TM1")
    same = stored is not None and again is not None and math.isclose(stored, again,
                                                                     rel_tol=1e-9)
    verdict = ("reproduces the run's stored numbers exactly" if same else
               f"DIFFERS from the stored M = {stored} (re-simulated M = {again})")
    feasible = (run.metrics.get("chosen") or {}).get("feasible")
    return (f"Fig. 10: chosen design (Eq. 21) of run {run.name or run.path.name} ({why}); "
            f"{'feasible' if feasible else 'INFEASIBLE (no feasible design found)'}. "
            f"Convergence time {check.get('convergence_time_TM1', math.nan):.1f} s, "
            f"accuracy {check.get('convergence_accuracy_TM1', math.nan):.3g} s^-2, "
            f"M = {again if again is not None else math.nan:.3g}. Time series re-simulated "
            f"with the run's problem configuration and noise seed "
            f"{run.config['problem'].get('noise_seed')}; the re-simulation {verdict}.")


# ---- benchmarks ---------------------------------------------------------------------
def benchmark_boxes(rows: list[dict], key: str, title: str, path: Path) -> None:
    """One panel per problem, one box per setting (algorithm, budget, ...)."""
    problems = sorted({r["setting"]["problem"] for r in rows})
    n = max(1, len(problems))
    cols = min(3, n)
    fig, axes = plt.subplots(math.ceil(n / cols), cols, figsize=(5 * cols, 3.8 *
                                                                  math.ceil(n / cols)),
                             squeeze=False)
    for ax, prob in zip(axes.flat, problems):
        sub = [r for r in rows if r["setting"]["problem"] == prob]
        data = [finite(r["values"][key]) for r in sub]
        # how many runs a box holds: runs without a feasible design have no IGD
        names = [f"{label(r['setting'], hide=('problem',))} (n={len(d)}/"
                 f"{len(r['values'][key])})" for r, d in zip(sub, data)]
        ax.set_title(prob)
        if not any(len(d) for d in data):
            note_nothing_to_draw(ax, f"no run has a finite {key.upper()} (no feasible "
                                 "design, or no reference front)")
            continue
        ax.boxplot([d if len(d) else [np.nan] for d in data], showmeans=True)
        ax.set_xticks(range(1, len(names) + 1), names, rotation=60, ha="right", fontsize=7)
        ax.set_ylabel(f"{key.upper()} [-]")
        log_if_spanning_decades(ax, np.concatenate([d for d in data if len(d)]))
    for ax in list(axes.flat)[len(problems):]:
        ax.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ---- anytime ----------------------------------------------------------------------------
#: Settings that get a panel each in the anytime figure (the rest are lines).
PANEL_KEYS = ("problem", "scheme", "problem.n_freq")


def anytime_curves(rows: list[dict], key: str, path: Path, log_x: bool = False,
                   xlabel: str = "real evaluations") -> None:
    """Mean ± std over seeds of ``key`` against evaluations, one line per setting.

    ``rows`` are summary rows whose settings include ``evaluations``; a line is solid
    where every run of the setting had reached that count and dotted where only some had.
    ``log_x``: logarithmic evaluation axis (for runs of very different lengths);
    ``xlabel``: what ``evaluations`` holds (e.g. wall-clock seconds).
    """
    panels: dict[tuple, dict[str, list[dict]]] = {}
    for row in rows:
        s = dict(row["setting"])
        k = float(s.pop("evaluations"))
        panel = tuple((p, s.pop(p)) for p in PANEL_KEYS if p in s)
        panels.setdefault(panel, {}).setdefault(label(s), []).append({**row, "k": k})
    n = max(1, len(panels))
    cols = min(3, n)
    wide = max(len(lines) for lines in panels.values()) > 6 if panels else False
    fig, axes = plt.subplots(math.ceil(n / cols), cols, squeeze=False,
                             figsize=((9 if wide else 5.5) * cols, 4 * math.ceil(n / cols)))
    ylabel = {"M_TM1": "M (TM1) of the chosen design, search draw",
              "heldout_M": "held-out M (TM1) of the chosen design"}.get(key, key.upper()) \
        + " [-]"
    for ax, (panel, lines) in zip(axes.flat, sorted(panels.items())):
        colours = plt.get_cmap("tab20" if len(lines) > 10 else "tab10")
        for i, (name, pts) in enumerate(lines.items()):
            _anytime_line(ax, sorted(pts, key=lambda r: r["k"]), key, name, colours(i))
        ax.set_title(", ".join(f"{k}={v}" for k, v in panel) or f"{ylabel}, mean ± std")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        if log_x:
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        if not ax.get_lines():
            note_nothing_to_draw(ax, f"no finite {ylabel.removesuffix(' [-]')} in any run "
                                 "(no feasible design yet)")
            continue
        log_if_spanning_decades(ax, [y for ln in ax.get_lines() for y in ln.get_ydata()])
        if len(lines) > 6:  # many settings: the legend beside the panel, not over it
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        else:
            ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _anytime_line(ax, pts: list[dict], key: str, name: str, colour) -> None:
    pts = [p for p in pts if p["n_complete"] > 0 and math.isfinite(p[key][0])]
    if not pts:
        return
    k = np.array([p["k"] for p in pts])
    mean = np.array([p[key][0] for p in pts])
    std = np.nan_to_num(np.array([p[key][1] for p in pts]))
    full = np.array([p["n_complete"] == p["n_runs"] for p in pts])
    if full.any():  # an empty line would still take a legend entry
        ax.plot(k[full], mean[full], color=colour, label=name)
    ax.fill_between(k, mean - std, mean + std, color=colour, alpha=0.1, lw=0)
    if not full.all():  # some runs stop short of here (unfinished or smaller budget)
        start = max(0, int(np.argmin(full)) - 1)
        ax.plot(k[start:], mean[start:], ":", color=colour,
                label=None if full.any() else name)


# ---- across problems ----------------------------------------------------------------------
def performance_profiles(panels: list[tuple[str, list[str], np.ndarray, int]],
                         path: Path) -> None:
    """Dolan-Moré performance profiles, one panel per metric.

    ``panels``: (title, algorithm names, ratios (problems, algorithms) from
    :func:`tmopt.reporting.across.performance_ratios`, problems no algorithm solved).
    """
    from tmopt.reporting.across import profile

    fig, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 4.2), squeeze=False)
    for ax, (title, names, ratios, unsolved) in zip(axes.flat, panels):
        finite_r = ratios[np.isfinite(ratios)]
        top = max(2.0, 1.2 * float(finite_r.max())) if finite_r.size else 2.0
        taus = np.geomspace(1.0, top, 400)
        rho = profile(ratios, taus)
        styles = ["-", "--", "-.", ":"]
        for i, name in enumerate(names):
            ax.step(taus, rho[:, i], where="post", label=display_name(name),
                    linestyle=styles[i % len(styles)], lw=1.6)
        ax.set_xscale("log", base=2)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("tau (within a factor tau of the best on the problem)")
        ax.set_ylabel("share of problems rho(tau)")
        extra = f"; {unsolved} solved by none, left out" if unsolved else ""
        ax.set_title(f"{title} ({len(ratios)} problems{extra})", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
