"""Tables of a sweep: per setting, mean ± std over seeds and the test against a reference.

Every table is written twice, as CSV (numbers, one column per statistic, for further
processing) and as Markdown (formatted ``mean ± std`` for reading). Only complete runs
enter the statistics; the ``runs`` column says how many of the setting's runs that is,
and the status table lists every run that is not complete.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from tmopt.files import atomic_write_text
from tmopt.reporting.paper import PAPER_TABLE3, TABLE3_COLUMNS, display_name
from tmopt.reporting.runs import COMPLETE, RunRecord
from tmopt.reporting.stats import fmt_mean_std, fmt_number, fmt_p, mark, mean_std, rank_sum

Setting = tuple[tuple[str, str], ...]
#: Keys in which a reference setting may differ when none matches exactly (flagged: †):
#: the run's size (an EA at the paper's 10 000 evaluations against the reference at 697).
RELAXED_KEYS = ("budget", "experiment")


@dataclass(frozen=True)
class Metric:
    """One column of a summary table.

    Attributes:
        key: Column id (CSV prefix).
        header: Markdown header.
        get: Value of a complete run (None when it has none).
        lower_is_better: Direction, for the +/-/= marks.
        tested: Whether the rank-sum test against the reference is computed (CSV).
        sci: Scientific notation (None: decide by magnitude).
        show_p: Whether the Markdown table shows that p-value too (tables stay readable).
        floor_flag: Name of the run's ``floor.below_floor`` entry for this value: the
            Markdown cell then says in how many runs it was below the physical floor
            (``‡k``: noise luck, not excitation quality; docs/noise.md).
    """

    key: str
    header: str
    get: Callable[[RunRecord], float | None]
    lower_is_better: bool = True
    tested: bool = False
    sci: bool | None = None
    show_p: bool = True
    floor_flag: str | None = None


def _ident(key: str) -> Callable[[RunRecord], float | None]:
    return lambda run: run.identification.get(key)


def _metric(key: str) -> Callable[[RunRecord], float | None]:
    return lambda run: (run.metrics or {}).get(key)


def _chosen_feasible(run: RunRecord) -> float:
    return float(bool(((run.metrics or {}).get("chosen") or {}).get("feasible")))


def _has_front(run: RunRecord) -> float:
    return float(((run.metrics or {}).get("pareto_size") or 0) > 0)


def _stage_two(run: RunRecord) -> float | None:
    """1 if the run reached MGSAEA's stage two, 0 if not, None for an algorithm without
    stages (``algorithm_summary`` of ``metrics.json``)."""
    stage = ((run.metrics or {}).get("algorithm_summary") or {}).get("stage_reached")
    return None if stage is None else float(stage >= 2)


def _heldout(quantity: str, stat: str = "mean") -> Callable[[RunRecord], float | None]:
    """The chosen design's held-out statistic (metrics.json ``heldout``)."""
    def get(run: RunRecord) -> float | None:
        block = (run.metrics or {}).get("heldout") or {}
        if quantity == "eq20_share":
            return block.get("eq20_share")
        return (block.get(quantity) or {}).get(stat)
    return get


def _front_best(run: RunRecord) -> float | None:
    best = ((run.metrics or {}).get("heldout_front") or {}).get("best_M") or {}
    return best.get("M_mean")


#: The search draw: what the optimiser saw for its chosen design (one noise draw under
#: ``fixed``, the mean of K under ``average``, a prediction under ``information``).
_SEARCH_FLAGS = {"convergence_accuracy_TM1": "identification.convergence_accuracy_TM1",
                 "M_TM1": "identification.M_TM1",
                 "final_accuracy_TM1": "identification.final_accuracy_TM1"}
TABLE3_METRICS: tuple[Metric, ...] = tuple(
    Metric(key, f"{header} search draw", _ident(key), tested=True, show_p=False,
           sci=None if "time" in key or key.startswith("M_") else True,
           floor_flag=_SEARCH_FLAGS.get(key))
    for key, header in TABLE3_COLUMNS)
#: Held-out re-scoring of the chosen design (mean over the run's held-out seeds): the
#: headline of Table 3 and Figs. 8-9; the Wilcoxon test is on held-out M.
HELDOUT_METRICS: tuple[Metric, ...] = (
    Metric("heldout_M", "M held-out", _heldout("M"), tested=True,
           floor_flag="heldout.M.mean"),
    Metric("M_TM1", "M search draw", _ident("M_TM1"), tested=True, show_p=False,
           floor_flag="identification.M_TM1"),
    Metric("heldout_M_std", "noise spread of M (std over held-out seeds)",
           _heldout("M", "std")),
    Metric("heldout_convergence_time", "convergence time held-out (s)",
           _heldout("convergence_time"), tested=True, show_p=False),
    Metric("heldout_convergence_accuracy", "convergence accuracy held-out (s^-2)",
           _heldout("convergence_accuracy"), tested=True, show_p=False, sci=True,
           floor_flag="heldout.convergence_accuracy.mean"),
    Metric("heldout_M(7e-11)", "M (7e-11) held-out", _heldout("M(7e-11)"), tested=True,
           show_p=False),
    Metric("heldout_M(5e-11)", "M (5e-11) held-out", _heldout("M(5e-11)"), tested=True,
           show_p=False),
    Metric("heldout_final_accuracy", "final accuracy held-out (s^-2)",
           _heldout("final_accuracy"), tested=True, show_p=False, sci=True,
           floor_flag="heldout.final_accuracy.mean"),
    Metric("heldout_eq20", "held-out runs keeping Eq. 20", _heldout("eq20_share"),
           lower_is_better=False, sci=False),
    Metric("front_best_M", "best held-out M on the front", _front_best, tested=True,
           show_p=False),
)
COMMON_METRICS: tuple[Metric, ...] = (
    Metric("n_evals", "real evaluations", _metric("n_evals"), sci=False),
    Metric("wall_time_s", "wall time per run (s)", _metric("wall_time_s"), sci=False),
    Metric("stage_two", "stage two reached", _stage_two),
)
STIFFNESS_METRICS = (
    Metric("chosen_feasible", "chosen feasible", _chosen_feasible),
    *HELDOUT_METRICS, *COMMON_METRICS)
#: Table 3's columns on the search draw (with the floor flags), table3_search_draw.md.
SEARCH_DRAW_METRICS = (
    Metric("chosen_feasible", "chosen feasible", _chosen_feasible),
    *TABLE3_METRICS, *COMMON_METRICS)
#: What an archive prefix gives (tmopt.reporting.anytime): no re-simulation, so no
#: stricter thresholds or final accuracy.
ANYTIME_STIFFNESS_METRICS = (
    *(m for m in HELDOUT_METRICS if m.key in ("heldout_M", "heldout_M_std", "heldout_eq20")),
    *(m for m in SEARCH_DRAW_METRICS if m.key in (
        "chosen_feasible", "convergence_time_TM1", "convergence_accuracy_TM1", "M_TM1")))
BENCHMARK_METRICS: tuple[Metric, ...] = (
    Metric("has_front", "feasible set found", _has_front),
    Metric("feasible_ratio", "feasible share", _metric("feasible_ratio"),
           lower_is_better=False, sci=False),  # of the run's evaluations
    Metric("igd", "IGD", _metric("igd"), tested=True),
    Metric("igd_plus", "IGD+", _metric("igd_plus")),
    Metric("hv", "HV", _metric("hv"), lower_is_better=False, tested=True),
    *COMMON_METRICS)
ANYTIME_BENCHMARK_METRICS = tuple(m for m in BENCHMARK_METRICS
                                  if m.key in ("has_front", "feasible_ratio", "igd",
                                               "igd_plus", "hv"))


# ---- summaries ------------------------------------------------------------------------
def summarise(groups: dict[Setting, list[RunRecord]], metrics: Sequence[Metric],
              reference: str | None) -> list[dict]:
    """One row per setting: counts, mean/std per metric, p-values against the reference.

    The reference of a setting is the setting with the same values of every key except
    ``algorithm = reference``; a tested metric of a setting without one has p = NaN.
    """
    values = {s: {m.key: [m.get(r) for r in _complete(runs)] for m in metrics}
              for s, runs in groups.items()}
    rows = []
    for setting, runs in groups.items():
        ref = _reference_setting(setting, reference, groups)
        row: dict = {"setting": dict(setting), "n_complete": len(_complete(runs)),
                     "n_runs": len(runs), "reference": dict(ref) if ref else None,
                     "values": values[setting],
                     "below_floor": {m.key: sum(_below_floor(r, m.floor_flag)
                                                for r in _complete(runs))
                                     for m in metrics if m.floor_flag}}  # fmt: skip
        for m in metrics:
            row[m.key] = mean_std(values[setting][m.key])
            if m.tested:
                ours = values[setting][m.key]
                theirs = values[ref][m.key] if ref and ref != setting else None
                _add_test(row, m, ours, theirs)
        rows.append(row)
    return rows


def _add_test(row: dict, m: Metric, ours: list, theirs: list | None) -> None:
    """``p_<key>`` and ``mark_<key>`` of ``ours`` against the reference's values (None: none)."""
    p = math.nan if theirs is None else rank_sum(ours, theirs)
    row[f"p_{m.key}"] = p
    row[f"mark_{m.key}"] = "" if theirs is None else mark(ours, theirs, p, m.lower_is_better)


def _below_floor(run: RunRecord, flag: str) -> bool:
    floor = (run.metrics or {}).get("floor") or {}
    return flag in (floor.get("below_floor") or [])


def first_floor(runs: list[RunRecord]) -> dict | None:
    """The physical floor block of the first run whose metrics.json has one."""
    return next((fl for run in runs if (fl := (run.metrics or {}).get("floor"))), None)


def floor_note(runs: list[RunRecord]) -> str:
    """One sentence: the physical floor of the runs' problem (the first run that has one)."""
    fl = first_floor(runs)
    if not fl:
        return ""
    return (f"Physical floor ({fl.get('parameter', 'k1xx')}, docs/noise.md): final "
            f"accuracy >= {fmt_number(fl['final_accuracy_mean'], True)} s^-2 (mean "
            f"|error|; rms {fmt_number(fl['final_accuracy_rms'], True)}), M >= "
            f"{fmt_number(fl['M'])} (at a convergence time of "
            f"{fl['M_at_convergence_time']:.0f} s); ‡k: k runs below their floor, "
            "which only noise luck gives.")


def _complete(runs: list[RunRecord]) -> list[RunRecord]:
    return [r for r in runs if r.status == COMPLETE]


def _reference_setting(setting: Setting, reference: str | None,
                       groups: dict[Setting, list[RunRecord]]) -> Setting | None:
    """The reference's setting with the same values; failing that, at another budget.

    The second case (e.g. an EA at 10 000 evaluations against the reference at 300, or
    from another preset) is taken only when the reference has exactly one such setting;
    the row is then flagged.
    """
    if not reference:
        return None
    target = tuple((k, reference if k == "algorithm" else v) for k, v in setting)
    if target in groups:
        return target
    for relaxed in ((), RELAXED_KEYS):  # algorithm parameters (algorithm.*) never match
        loose = [s for s in groups if _same_but(s, target, relaxed)]
        if len(loose) == 1:
            return loose[0]
    return None


def _same_but(a: Setting, b: Setting, keys: tuple[str, ...]) -> bool:
    """Equal settings except in ``keys`` and in parameters of the algorithm itself."""
    return len(a) == len(b) and all(
        x == y or x[0] in keys or x[0].startswith("algorithm.") for x, y in zip(a, b))


# ---- formatting -------------------------------------------------------------------------
def label(setting: dict, hide: Sequence[str] = ()) -> str:
    """``NSGA-II (budget=300)``: the algorithm's display name, then the other keys (a key
    the algorithm does not have, value ``""``, is left out)."""
    algo = setting.get("algorithm")
    rest = [f"{k}={v}" for k, v in setting.items()
            if k not in (*hide, "algorithm") and v != ""]
    name = display_name(algo) if algo else ""
    if not rest:
        return name
    return f"{name} ({', '.join(rest)})" if name else ", ".join(rest)


def markdown_rows(rows: list[dict], metrics: Sequence[Metric], keys: Sequence[str],
                  reference: str | None) -> tuple[list[str], list[list[str]]]:
    """Header and body of a Markdown summary table (p columns only where one is finite)."""
    tested = {m.key for m in metrics if m.tested and m.show_p and reference and any(
        math.isfinite(r.get(f"p_{m.key}", math.nan)) for r in rows)}
    header = [*keys, "runs"]
    for m in metrics:
        header.append(m.header)
        if m.key in tested:
            header.append(f"p ({m.header}) vs {display_name(reference)}")
    body = []
    for row in rows:
        cells = [_setting_cell(row["setting"], k) for k in keys]
        cells.append(f"{row['n_complete']}/{row['n_runs']}")
        for m in metrics:
            cells.append(_cell(row, m))
            if m.key in tested:
                p = row.get(f"p_{m.key}", math.nan)
                flag = "†" if _relaxed(row) and math.isfinite(p) else ""
                cells.append(f"{fmt_p(p)}{flag} {row.get(f'mark_{m.key}', '')}".strip())
        body.append(cells)
    return header, body


def _relaxed(row: dict) -> bool:
    """Whether the reference differs in more than the algorithm and its own parameters."""
    ref = row.get("reference")
    return bool(ref) and any(ref.get(k) != v for k, v in row["setting"].items()
                             if k != "algorithm" and not k.startswith("algorithm."))


def _setting_cell(setting: dict, key: str) -> str:
    value = str(setting.get(key, ""))
    return display_name(value) if key == "algorithm" else value


def _cell(row: dict, m: Metric) -> str:
    if m.key in ("chosen_feasible", "has_front", "stage_two"):
        vals = [v for v in row["values"][m.key] if v is not None]
        return f"{int(sum(vals))}/{len(vals)}" if vals else "n/a"
    below = (row.get("below_floor") or {}).get(m.key, 0)
    return fmt_mean_std(row["values"][m.key], m.sci) + (f" ‡{below}" if below else "")


def csv_rows(rows: list[dict], metrics: Sequence[Metric], keys: Sequence[str]) -> list[dict]:
    """Flat numeric rows: setting keys, counts, ``<metric>_mean/_std/_n``, ``p_<metric>``."""
    out = []
    for row in rows:
        flat = {k: row["setting"].get(k, "") for k in keys}
        flat.update(n_complete=row["n_complete"], n_runs=row["n_runs"])
        for m in metrics:
            mean, std, n = row[m.key]
            flat.update({f"{m.key}_mean": mean, f"{m.key}_std": std, f"{m.key}_n": n})
            if m.floor_flag:
                flat[f"{m.key}_below_floor"] = row["below_floor"][m.key]
            if f"p_{m.key}" in row:
                flat[f"p_{m.key}"] = row[f"p_{m.key}"]
                flat[f"mark_{m.key}"] = row[f"mark_{m.key}"]
        out.append(flat)
    return out


#: Held-out counterparts of Table 3's columns (metrics of HELDOUT_METRICS).
_HELDOUT_OF = {"convergence_time_TM1": "heldout_convergence_time",
               "convergence_accuracy_TM1": "heldout_convergence_accuracy",
               "M_TM1": "heldout_M", "M_TM1@7e-11": "heldout_M(7e-11)",
               "M_TM1@5e-11": "heldout_M(5e-11)",
               "final_accuracy_TM1": "heldout_final_accuracy"}


def paper_comparison(rows: list[dict], heldout: list[dict] | None = None
                     ) -> tuple[list[str], list[list[str]]]:  # fmt: skip
    """Our Table 3 means beside the paper's single values, one line per source: the
    search draw (``rows``, SEARCH_DRAW_METRICS) and, when given, the held-out scores
    (``heldout``, the same settings summarised with STIFFNESS_METRICS)."""
    header = ["algorithm", "source", *(h for _, h in TABLE3_COLUMNS)]
    body = []
    for i, row in enumerate(rows):
        algo = row["setting"].get("algorithm", "")
        ours = [fmt_number(row[k][0], _sci(k)) for k, _ in TABLE3_COLUMNS]
        body.append([label(row["setting"]), f"ours, search draw (mean of "
                     f"{row['n_complete']})", *ours])
        held = next((h for h in heldout or [] if h["setting"] == row["setting"]), None)
        if held is not None:
            body.append([label(row["setting"]), f"ours, held-out (mean of "
                         f"{held['n_complete']})", *(fmt_number(held[_HELDOUT_OF[k]][0],
                                                                _sci(k))
                                                     for k, _ in TABLE3_COLUMNS)])
        last_of_algo = i + 1 == len(rows) or rows[i + 1]["setting"].get("algorithm") != algo
        if algo in PAPER_TABLE3 and last_of_algo:
            paper = [fmt_number(v, _sci(k)) for (k, _), v in zip(TABLE3_COLUMNS,
                                                                 PAPER_TABLE3[algo])]
            body.append([display_name(algo), "paper", *paper])
    return header, body


def _sci(key: str) -> bool | None:
    return None if "time" in key or key.startswith("M_") else True


# ---- writing ----------------------------------------------------------------------------
def to_markdown(header: Sequence[str], body: Sequence[Sequence[str]]) -> str:
    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"
    return "\n".join([line(header), line(["---"] * len(header)), *map(line, body)]) + "\n"


def to_csv(rows: list[dict]) -> str:
    if not rows:
        return ""
    fields: list[str] = []
    for row in rows:
        fields += [k for k in row if k not in fields]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=fields)
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _csv_value(v) for k, v in row.items()})
    return buf.getvalue()


def _csv_value(v):
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return v


def write_table(out: Path, stem: str, title: str, header: Sequence[str],
                body: Sequence[Sequence[str]], rows_csv: list[dict], note: str = "") -> None:
    """``<stem>.csv`` (numbers) and ``<stem>.md`` (title, table, note)."""
    atomic_write_text(out / f"{stem}.csv", to_csv(rows_csv))
    text = f"## {title}\n\n{to_markdown(header, body)}"
    if note:
        text += f"\n{note.strip()}\n"
    atomic_write_text(out / f"{stem}.md", text)
