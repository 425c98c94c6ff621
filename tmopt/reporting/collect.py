"""Collect a sweep: ``python -m tmopt.collect SWEEP_DIR... [--out DIR] [--reference-algorithm A]``.

Reads every run folder under SWEEP_DIR (any launcher; several sweeps may share it, and
several folders may be given) and writes into ``--out`` (default
``SWEEP_DIR/collected``):

- ``summary.md``: what was found and written, with the runs' total and elapsed time;
- ``runs.csv``: one line per run (status, settings, seed, every number);
- ``status.md/.csv``: every run that is not complete (failed: its error; incomplete:
  evaluations done so far), and duplicates left out of the statistics;
- stiffness problem: ``table3.md/.csv`` (scheme B, 3 frequencies, one row per algorithm:
  the chosen design's held-out scores -- M on the held-out noise seeds is the headline,
  the search-draw M beside it -- as mean ± std over seeds and the Wilcoxon rank-sum
  p-value of held-out M against the reference algorithm), ``table3_search_draw.md/.csv``
  (Table 3's columns on the search draw), ``table3_vs_paper.md``, ``configurations.md/
  .csv`` (every scheme x k setting) with ``fig8.png`` and ``fig9.png``, and
  ``fig10.png/.csv`` (the best held-out design's motion and its identification curves on
  the held-out seeds, re-simulated); cells below the physical floor are marked ``‡k``
  (docs/noise.md);
- benchmark suites: ``benchmarks.md/.csv`` (IGD, IGD+, HV mean ± std, p-values of IGD and
  HV against the reference) with ``benchmarks_igd.png`` and ``benchmarks_hv.png``.
- with ``--at K[,K...]``: ``anytime.md/.csv`` (every setting after its runs' first K real
  evaluations: the choice each run would report had it stopped there, incomplete runs
  included as far as they got, tested against the reference at the same K) and
  ``anytime.png`` (M, or HV, against evaluations; tmopt.reporting.anytime).

Settings are the keys whose effective value differs between runs (tmopt.reporting.runs);
statistics use complete runs only, and every table says how many of a setting's runs
that is.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from tmopt.files import atomic_write_text
from tmopt.reporting import across, anytime, figures
from tmopt.reporting.paper import algorithm_order, display_name
from tmopt.reporting.runs import (
    COMPLETE,
    RunRecord,
    deduplicate,
    discover_runs,
    group_runs,
    setting_keys,
)
from tmopt.reporting.stats import fmt_number
from tmopt.reporting.tables import (
    ANYTIME_BENCHMARK_METRICS,
    ANYTIME_STIFFNESS_METRICS,
    BENCHMARK_METRICS,
    SEARCH_DRAW_METRICS,
    STIFFNESS_METRICS,
    csv_rows,
    first_floor,
    floor_note,
    markdown_rows,
    paper_comparison,
    summarise,
    to_csv,
    write_table,
)

log = logging.getLogger("tmopt.collect")
DEFAULT_REFERENCE = "mgsaea_ipc"
#: The paper's optimal configuration (Sec. 4.4), the setting of Table 3.
TABLE3_SETTING = {"scheme": "B", "problem.n_freq": "3"}
HELDOUT_NOTE = ("Held-out: every run's chosen design simulated on the same held-out noise "
                "seeds, which no search can draw (docs/noise.md); p is of held-out M.")
TEST_NOTE = ("p: two-sided Wilcoxon rank-sum test (scipy.stats.mannwhitneyu, exact for "
             "small samples without ties) over seeds against the reference's runs in the same "
             "setting; + / - / = : significantly better / worse / no significant difference "
             "at 0.05 (by the medians). The reference's runs are those with the same settings "
             "apart from the algorithm's own parameters (algorithm.*); †: at another budget "
             "or preset (it has none at this one). n/a: fewer than 2 complete runs on a "
             "side, or no reference runs to compare with.")


def collect(sweep_dir: Path | list[Path], out: Path | None = None,
            reference: str = DEFAULT_REFERENCE, fig10_run: Path | None = None,
            fig10: bool = True, at: list[int] | None = None, rescore: bool = False,
            at_seeds: int | None = None) -> list[Path]:
    """Write every table and figure of the sweep(s) in ``sweep_dir``; return the files written.

    ``at``: evaluation counts of the anytime view; ``at_seeds``: held-out seeds its chosen
    stiffness designs are re-scored on (None: each run's own; 0: search draws only).

    Several sweep folders (a list) are collected as one: e.g. the same algorithms at two
    budgets from two sweeps, so that they share one table and one reference.
    ``rescore``: the suite runs' IGD, IGD+ and HV are recomputed from their archives
    against today's fronts (runs made before a front was corrected).
    """
    dirs = [Path(d) for d in (sweep_dir if isinstance(sweep_dir, list) else [sweep_dir])]
    if out is None and len(dirs) > 1:
        raise FileNotFoundError("several sweep folders need --out")
    out = Path(out) if out is not None else dirs[0] / "collected"
    runs, duplicates = deduplicate(_discover(dirs))
    if not runs:
        raise FileNotFoundError(f"no run folders under {', '.join(map(str, dirs))}")
    if rescore:
        runs = [anytime.rescored(r) if not r.is_stiffness else r for r in runs]
    out.mkdir(parents=True, exist_ok=True)
    notes = [_write_runs(runs, out), _write_status(runs, duplicates, out)]
    stiffness = [r for r in runs if r.is_stiffness]
    suites = [r for r in runs if not r.is_stiffness]
    if stiffness:
        notes += _write_stiffness(stiffness, out, reference, fig10_run if fig10 else None,
                                  fig10)
    if suites:
        notes.append(_write_benchmarks(suites, out, reference))
        notes.append(_write_across(suites, out, reference))
    if at:
        notes.append(_write_anytime(runs, out, reference, at, at_seeds))
    label = ", ".join(map(str, dirs))
    atomic_write_text(out / "summary.md", _summary(label, runs, duplicates, notes))
    return sorted(p for p in out.iterdir() if p.is_file())


def _discover(dirs: list[Path]) -> list[RunRecord]:
    """Runs of every folder; names carry the folder's name when there are several."""
    runs = []
    for d in dirs:
        found = discover_runs(d)
        if len(dirs) > 1:
            for run in found:
                run.name = f"{d.name}/{run.name}"
        runs += found
    return runs


# ---- every run ------------------------------------------------------------------------
def _write_runs(runs: list[RunRecord], out: Path) -> str:
    keys = setting_keys(runs)
    rows = [_run_row(r, keys) for r in runs]
    atomic_write_text(out / "runs.csv", to_csv(rows))
    return f"`runs.csv`: {len(runs)} runs, one line each (settings: {', '.join(keys)})."


def _run_row(run: RunRecord, keys: list[str]) -> dict:
    m = run.metrics or {}
    row = {"path": run.name, "status": run.status, **{k: run.value(k) for k in keys},
           "seed": run.seed, "budget": run.budget, "n_evals": run.n_evals,
           "chosen_feasible": ((m.get("chosen") or {}).get("feasible")),
           "feasible_ratio": m.get("feasible_ratio"), "pareto_size": m.get("pareto_size")}
    for key in ("igd", "igd_plus", "hv", "wall_time_s"):
        row[key] = m.get(key)
    row.update({k: v for k, v in run.identification.items() if isinstance(v, (int, float))})
    row["error"] = (run.failure or {}).get("message", "")
    return row


def _write_status(runs: list[RunRecord], duplicates: list[RunRecord], out: Path) -> str:
    bad = [r for r in runs if r.status != COMPLETE]
    rows = [{"path": r.name, "status": r.status, "seed": r.seed,
             "evaluations": f"{r.n_evals if r.n_evals is not None else '?'}/{r.budget}",
             "reason": _reason(r)} for r in bad]
    rows += [{"path": r.name, "status": "duplicate (left out)", "seed": r.seed,
              "evaluations": f"{r.n_evals}/{r.budget}",
              "reason": "same configuration and seed as another complete run"}
             for r in duplicates]
    header = ["path", "status", "seed", "evaluations", "reason"]
    body = [[str(row[h]) for h in header] for row in rows]
    if not body:
        body = [["(none)", "every run is complete", "", "", ""]]
    write_table(out, "status", "Runs that are not complete", header, body, rows,
                "Failed runs stopped on an error (failure.json); incomplete runs have no "
                "complete metrics.json (interrupted or still running): re-running the same "
                "sweep command resumes them and skips the finished ones.")
    return (f"`status.md`: {sum(r.status == 'failed' for r in bad)} failed, "
            f"{sum(r.status == 'incomplete' for r in bad)} incomplete, "
            f"{len(duplicates)} duplicate runs.")


def _reason(run: RunRecord) -> str:
    if run.failure:
        return f"{run.failure.get('error', 'error')}: {run.failure.get('message', '')}"
    last = _last_log_line(run.path / "tmopt.log")
    tail = f"; last log line: {last}" if last else ""
    if run.n_evals is None:
        return "no archive yet: the run never evaluated a design (or is starting)" + tail
    return ("no complete metrics.json: interrupted, still running, or stopped by an "
            "unexpected error (the sweep's console shows its traceback)" + tail)


def _last_log_line(path: Path) -> str:
    try:
        lines = [ln.strip() for ln in path.read_text().splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1][-200:] if lines else ""


# ---- stiffness --------------------------------------------------------------------------
def _write_stiffness(runs: list[RunRecord], out: Path, reference: str,
                     fig10_run: Path | None, fig10: bool) -> list[str]:
    keys = _with(setting_keys(runs), ("scheme", "problem.n_freq"))
    keys = [k for k in keys if k != "problem"]
    rows = _sorted(summarise(group_runs(runs, keys), STIFFNESS_METRICS, reference))
    header, body = markdown_rows(rows, STIFFNESS_METRICS, keys, reference)
    write_table(out, "configurations", "Stiffness problem: every configuration (Figs. 8-9)",
                header, body, csv_rows(rows, STIFFNESS_METRICS, keys),
                "Chosen design (Eq. 21) of each run, TM1's numbers (the key test mass), "
                "re-scored on the held-out noise seeds (mean over them per run; then mean ± "
                "std over runs); 'search draw': what the search saw. " + HELDOUT_NOTE + " "
                + floor_note(runs) + " " + TEST_NOTE)
    figures.fig8(rows, out / "fig8.png")
    floor = first_floor(runs)
    figures.fig9(rows, out / "fig9.png", floor.get("M") if floor else None)
    notes = [f"`configurations.md`, `fig8.png`, `fig9.png`: {len(rows)} stiffness "
             f"settings ({', '.join(keys)})."]
    t3_runs = [r for r in runs if all(r.value(k) == v for k, v in TABLE3_SETTING.items())]
    if t3_runs:
        notes.append(_write_table3(t3_runs, out, reference))
    else:
        notes.append("Table 3 not written: no run of scheme B with 3 frequencies.")
    if fig10:
        notes.append(_write_fig10(t3_runs or runs, out, reference, fig10_run))
    return notes


def _write_table3(runs: list[RunRecord], out: Path, reference: str) -> str:
    keys = [k for k in setting_keys(runs) if k not in (*TABLE3_SETTING, "problem")]
    groups = group_runs(runs, keys)
    rows = _sorted(summarise(groups, STIFFNESS_METRICS, reference))
    header, body = markdown_rows(rows, STIFFNESS_METRICS, keys, reference)
    floor = floor_note(runs)
    write_table(out, "table3", "Table 3: scheme B, 3 frequencies (18 variables), held-out",
                header, body, csv_rows(rows, STIFFNESS_METRICS, keys),
                "Chosen design (Eq. 21) of each run; per run the mean over the held-out "
                "seeds, then mean ± std over runs. 'chosen feasible': runs whose chosen "
                "design satisfies every constraint (otherwise the least-violating design is "
                "reported). 'M search draw': the value the search saw. 'best held-out M on "
                "the front': the best design of the run's final front, re-scored alike. "
                + HELDOUT_NOTE + " table3.csv holds every column's p-value. " + floor + " "
                + TEST_NOTE)
    draw = _sorted(summarise(groups, SEARCH_DRAW_METRICS, reference))
    d_header, d_body = markdown_rows(draw, SEARCH_DRAW_METRICS, keys, None)
    write_table(out, "table3_search_draw", "Table 3's columns on the search draw",
                d_header, d_body, csv_rows(draw, SEARCH_DRAW_METRICS, keys),
                "The chosen design's numbers as the search scored them (noise=fixed: one "
                "noise draw, the paper's protocol; average: the mean of K; information: the "
                "prediction), mean ± std over runs. " + floor)
    p_header, p_body = paper_comparison(draw, rows)
    atomic_write_text(out / "table3_vs_paper.md",
                      "## Table 3: ours (mean over seeds) beside the paper's single run\n\n"
                      + _md(p_header, p_body) + ("\n" + floor + "\n" if floor else ""))
    return (f"`table3.md`, `table3_search_draw.md`, `table3_vs_paper.md`: {len(rows)} rows "
            f"({', '.join(keys)}).")


def _write_fig10(runs: list[RunRecord], out: Path, reference: str,
                 chosen: Path | None) -> str:
    run, why = _fig10_choice(runs, reference, chosen)
    if run is None:
        return "Fig. 10 not drawn: no complete stiffness run."
    caption = figures.fig10(run, out / "fig10.png", out / "fig10.csv", why)
    atomic_write_text(out / "fig10.md", f"![Fig. 10](fig10.png)\n\n{caption}\n")
    return f"`fig10.png`, `fig10.md`, `fig10.csv`: {caption}"


def _fig10_choice(runs: list[RunRecord], reference: str,
                  chosen: Path | None) -> tuple[RunRecord | None, str]:
    """The run asked for, else the best excitation: the feasible chosen design with the
    least held-out mean M of all runs (runs without held-out scores: the reference
    algorithm's median run by its search-draw M, as before held-out scoring)."""
    done = [r for r in runs if r.status == COMPLETE and r.identification.get("M_TM1")
            is not None]
    if chosen is not None:
        match = [r for r in done if r.path.resolve() == Path(chosen).resolve()]
        if not match:
            raise FileNotFoundError(f"--fig10-run {chosen} is not a complete stiffness run")
        return match[0], "run chosen on the command line"
    scored = [r for r in done if _heldout_m(r) is not None
              and ((r.metrics or {}).get("chosen") or {}).get("feasible")]
    if scored:
        best = min(scored, key=_heldout_m)
        return best, (f"the best excitation: the least held-out mean M over the "
                      f"{len(scored)} runs with a feasible chosen design "
                      f"({display_name(best.value('algorithm'))})")
    pool = [r for r in done if r.value("algorithm") == reference] or done
    if not pool:
        return None, ""
    pool.sort(key=lambda r: r.identification["M_TM1"])
    median = pool[(len(pool) - 1) // 2]
    return median, (f"median run by search-draw M over {len(pool)} run(s), "
                    f"M = {fmt_number(median.identification['M_TM1'])}")


def _heldout_m(run: RunRecord) -> float | None:
    return (((run.metrics or {}).get("heldout") or {}).get("M") or {}).get("mean")


# ---- benchmarks -------------------------------------------------------------------------
def _write_benchmarks(runs: list[RunRecord], out: Path, reference: str) -> str:
    keys = _with(setting_keys(runs), ("problem",))
    rows = summarise(group_runs(runs, keys), BENCHMARK_METRICS, reference)
    rows.sort(key=_setting_order)
    header, body = markdown_rows(rows, BENCHMARK_METRICS, keys, reference)
    write_table(out, "benchmarks", "Benchmark suites: IGD, IGD+ and HV of the final feasible "
                "non-dominated set", header, body, csv_rows(rows, BENCHMARK_METRICS, keys),
                "IGD/IGD+ against the offline true front (lower is better); HV of the set "
                "normalised by the true front's ideal and nadir, reference point 1.1 (higher "
                "is better); a run without any feasible design has no IGD and HV 0. 'feasible "
                "set found': runs with at least one feasible design; 'feasible share': the "
                "share of a run's evaluations that were feasible (mean over runs). "
                + TEST_NOTE)
    figures.benchmark_boxes(rows, "igd", "IGD over seeds (lower is better)",
                            out / "benchmarks_igd.png")
    figures.benchmark_boxes(rows, "hv", "HV over seeds (higher is better)",
                            out / "benchmarks_hv.png")
    return f"`benchmarks.md`, `benchmarks_igd.png`, `benchmarks_hv.png`: {len(rows)} settings."


# ---- across problems ----------------------------------------------------------------------
def _write_across(runs: list[RunRecord], out: Path, reference: str) -> str:
    """``across_problems.md`` (Friedman + Holm per metric) and ``profiles.png``
    (performance profiles): every setting but the algorithm's is a problem (block)."""
    keys = setting_keys(runs)
    # an algorithm.* key splits the treatments only where it varies within one algorithm
    # (KTS has no "gap": that alone must not make MGSAEA-IPC's gap a setting)
    own = [k for k in keys if k.startswith("algorithm.") and any(
        len({r.value(k) for r in runs if r.value("algorithm") == a}) > 1
        for a in {r.value("algorithm") for r in runs})]
    treat = ["algorithm", *own]
    blocks_keys = [k for k in _with(keys, ("problem",))
                   if k != "algorithm" and not k.startswith("algorithm.")]
    if len({r.value("algorithm") for r in runs}) < 2 and not own:
        return "`across_problems.md` not written: one algorithm only."
    lines = ["## Across problems: Friedman test, Holm's post-hoc, performance profiles", "",
             "Each problem (every setting but the algorithm's: " + ", ".join(blocks_keys)
             + ") gives one number per algorithm, the median over its complete runs (IGD: "
             "a run without a feasible design counts as infinite; HV: as 0); problems "
             "without runs of every algorithm are left out. Ranks: 1 = best on a "
             "problem, ties shared. Friedman's chi2 and Iman-Davenport's F test whether "
             "the algorithms differ at all; each algorithm is then compared with the "
             f"reference ({reference}) by z = (R_i - R_ref) / sqrt(k (k+1) / (6 N)), "
             "two-sided, Holm-adjusted over the k-1 comparisons (Demšar, JMLR 7, 2006); "
             "+ / - / = : better / worse ranked than the reference, significant at 0.05 "
             "after Holm, or not. profiles.png: Dolan-Moré performance profiles of the "
             "same medians (IGD as the cost, and 1/HV).", ""]
    panels = []
    for metric in across.ACROSS_METRICS:
        blocks, names, table = across.block_table(runs, metric, blocks_keys, treat)
        header, body, text = across.friedman_rows(blocks, names, table, metric,
                                                  reference if treat == ["algorithm"]
                                                  else None)
        lines += [text, ""] + ([_md(header, body), ""] if body else [])
        if metric != "igd_plus" and len(blocks) and len(names) > 1:
            lower, _ = across.ACROSS_METRICS[metric]
            ratios, unsolved = across.performance_ratios(table, lower)
            cost = "IGD" if lower else "1 / HV"
            panels.append((f"{metric.upper()} (cost: {cost})", names, ratios, unsolved))
    if panels:
        figures.performance_profiles(panels, out / "profiles.png")
    atomic_write_text(out / "across_problems.md", "\n".join(lines) + "\n")
    return ("`across_problems.md`" + (", `profiles.png`" if panels else "")
            + ": Friedman + Holm and performance profiles across problems.")


# ---- anytime ----------------------------------------------------------------------------
def _write_anytime(runs: list[RunRecord], out: Path, reference: str, at: list[int],
                   at_seeds: int | None = None) -> str:
    """``anytime.md/.csv`` at the counts ``at``, ``anytime.png`` on a grid of counts (with
    ``_stiffness``/``_benchmarks`` in the names when a sweep holds both kinds)."""
    kinds = [kind for kind in (True, False) if any(r.is_stiffness == kind for r in runs)]
    notes = []
    for stiffness in kinds:
        stem = "anytime" if len(kinds) == 1 else (
            "anytime_stiffness" if stiffness else "anytime_benchmarks")
        part = [r for r in runs if r.is_stiffness == stiffness]
        notes.append(_write_anytime_kind(part, out, reference, at, stiffness, stem, at_seeds))
    return " ".join(notes)


def _write_anytime_kind(runs: list[RunRecord], out: Path, reference: str, at: list[int],
                        stiffness: bool, stem: str, at_seeds: int | None = None) -> str:
    grid = anytime.curve_counts(runs, at)
    records = [rec for run in runs for rec in anytime.anytime_records(run, grid, at_seeds)]
    heldout = stiffness and any((r.metrics or {}).get("heldout") for r in records)
    metrics = ANYTIME_STIFFNESS_METRICS if stiffness else ANYTIME_BENCHMARK_METRICS
    if stiffness and not heldout:  # search draws only (at_seeds=0, or no held-out seeds)
        metrics = tuple(m for m in metrics if not m.key.startswith("heldout"))
    keys = [k for k in _with(setting_keys(runs), ("problem",))
            if not (stiffness and k == "problem")] + [anytime.EVALS_KEY]
    rows = summarise(group_runs(records, keys), metrics, reference)
    rows.sort(key=lambda r: (int(r["setting"][anytime.EVALS_KEY]), _setting_order(r)))
    shown = [r for r in rows if int(r["setting"][anytime.EVALS_KEY]) in at]
    header, body = markdown_rows(shown, metrics, keys, reference)
    key = ("heldout_M" if heldout else "M_TM1") if stiffness else "hv"
    scored = ("'held-out': that design re-simulated on held-out noise seeds, which no "
              "search drew (the headline); 'search draw': the archived objectives the "
              "optimiser saw. " if heldout else "numbers from the archived objectives "
              "(search draws). ")
    write_table(out, stem, "After the first K real evaluations of each run", header,
                body, csv_rows(shown, metrics, keys),
                "Each run's archive cut after its first K evaluations and its final choice "
                "taken there (Eq. 21 on the feasible non-dominated set, else the least "
                "violating design); " + scored + "runs: runs that "
                "reached K / all runs of the setting (unfinished runs count as far as they "
                "got). " + TEST_NOTE)
    lengths = [r.budget or r.n_evals or 0 for r in runs]
    log_x = min(lengths) > 0 and max(lengths) > 5 * min(lengths)  # e.g. 697 beside 10 000
    figures.anytime_curves(rows, key, out / f"{stem}.png", log_x)
    where = "stiffness problem" if stiffness else "benchmark suites"
    note = (f"`{stem}.md`, `{stem}.png`: {where}, after {', '.join(map(str, at))} "
            f"evaluations ({len(runs)} runs).")
    if stiffness:  # its headline is held-out M, re-simulated per K: evaluations only
        return note
    return note + _write_anytime_seconds(runs, out, reference, metrics, keys, key, stem)


def _write_anytime_seconds(runs, out, reference, metrics, keys, key, stem) -> str:
    """``{stem}_seconds.png/.csv`` (benchmark suites): the same against wall-clock seconds
    (each run's evaluation_clock)."""
    grid = anytime.seconds_grid(runs)
    if not grid:
        return ""
    records = [rec for run in runs for rec in anytime.clock_records(run, grid)]
    keys = [k if k != anytime.EVALS_KEY else anytime.SECONDS_KEY for k in keys]
    rows = summarise(group_runs(records, keys), metrics, reference)
    for row in rows:  # the figure's x axis is the pseudo-setting "evaluations"
        row["setting"] = {(anytime.EVALS_KEY if k == anytime.SECONDS_KEY else k): v
                          for k, v in row["setting"].items()}
    figures.anytime_curves(rows, key, out / f"{stem}_seconds.png", log_x=True,
                           xlabel="wall-clock seconds (surrogate, search and evaluation)")
    atomic_write_text(out / f"{stem}_seconds.csv", to_csv(csv_rows(rows, metrics, [
        anytime.EVALS_KEY if k == anytime.SECONDS_KEY else k for k in keys])))
    return (f" `{stem}_seconds.png/.csv`: the same against wall-clock time (runs with an "
            f"evaluation clock; a line ends where its runs ended).")


def _setting_order(row: dict) -> tuple:
    return (row["setting"].get("problem", ""), *_row_order(row))


# ---- helpers ----------------------------------------------------------------------------
def _with(keys: list[str], extra: tuple[str, ...]) -> list[str]:
    return [*keys, *(k for k in extra if k not in keys)]


def _row_order(row: dict) -> tuple:
    s = row["setting"]
    return (algorithm_order(s.get("algorithm", "")), s.get("algorithm", ""),
            tuple(sorted((k, v) for k, v in s.items() if k != "algorithm")))


def _sorted(rows: list[dict]) -> list[dict]:
    def key(row: dict) -> tuple:
        s = row["setting"]
        n_freq = s.get("problem.n_freq", "0")
        return (s.get("scheme", ""), int(n_freq) if n_freq.isdigit() else 0, _row_order(row))
    return sorted(rows, key=key)


def _md(header, body) -> str:
    from tmopt.reporting.tables import to_markdown

    return to_markdown(header, body)


def _summary(sweep_dir: str, runs: list[RunRecord], duplicates: list[RunRecord],
             notes: list[str]) -> str:
    done = [r for r in runs if r.status == COMPLETE]
    total = sum((r.metrics or {}).get("wall_time_s", 0.0) for r in done)
    lines = [f"# Sweep {sweep_dir}", "",
             f"{len(runs)} runs ({len(done)} complete); {len(duplicates)} duplicates left out.",
             f"Sum of the complete runs' optimisation wall times: {total:.0f} s "
             f"({total / 3600:.2f} h); elapsed from the first run's start to the last run's "
             f"end (file times): {_elapsed(runs):.0f} s.", "", "Written:", ""]
    lines += [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def _elapsed(runs: list[RunRecord]) -> float:
    starts = [p.stat().st_mtime for r in runs for p in [r.path / ".hydra" / "config.yaml"]
              if p.exists()]
    ends = [p.stat().st_mtime for r in runs for p in [r.path / "metrics.json"] if p.exists()]
    return max(ends) - min(starts) if starts and ends else float("nan")


# ---- command line -----------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tmopt.collect", description=__doc__.split(
        "\n")[0])
    ap.add_argument("sweep_dir", type=Path, nargs="+",
                    help="sweep folder (e.g. multirun/quick); several are collected as one")
    ap.add_argument("--out", type=Path, default=None,
                    help="default: SWEEP_DIR/collected (required for several folders)")
    ap.add_argument("--reference-algorithm", default=DEFAULT_REFERENCE,
                    help="algorithm the others are tested against (default: mgsaea_ipc)")
    ap.add_argument("--fig10-run", type=Path, default=None,
                    help="run folder whose chosen design Fig. 10 shows (default: the "
                         "reference algorithm's median run by M)")
    ap.add_argument("--no-fig10", action="store_true", help="skip Fig. 10's re-simulation")
    ap.add_argument("--rescore", action="store_true",
                    help="recompute the suite runs' IGD, IGD+ and HV from their archives "
                         "against today's fronts (metrics.json stays as written)")
    ap.add_argument("--at", default=None, metavar="K[,K...]",
                    help="also write anytime.md/.png: every setting after its runs' first K "
                         "real evaluations (e.g. --at 300,400,697)")
    ap.add_argument("--at-seeds", type=int, default=None, metavar="S",
                    help="held-out noise seeds each chosen stiffness design of --at is "
                         "re-scored on (default: the run's problem.heldout_seeds; 0: the "
                         "search draws only; ~0.4 s per seed and distinct design)")
    args = ap.parse_args(argv)
    if args.at_seeds is not None and not 0 <= args.at_seeds <= 100_000:
        ap.error(f"--at-seeds must be an integer in [0, 100000], got {args.at_seeds}")
    try:
        at = None if args.at is None else anytime.parse_counts(args.at)
    except ValueError as exc:
        ap.error(str(exc))
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    try:
        files = collect(args.sweep_dir, args.out, args.reference_algorithm, args.fig10_run,
                        fig10=not args.no_fig10, at=at, at_seeds=args.at_seeds,
                        rescore=args.rescore)
    except FileNotFoundError as exc:
        print(f"tmopt.collect: error: {exc}", file=sys.stderr)
        return 2
    print((files[0].parent / "summary.md").read_text() if files else "nothing written")
    return 0


if __name__ == "__main__":
    sys.exit(main())
