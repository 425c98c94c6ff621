"""How often MGSAEA's stage two runs: per setting of a sweep, from each run's metrics.json.

    python experiments/stage_study.py multirun/frontier_stage --keys problem,algorithm.threshold

Prints a Markdown table: for every setting of ``--keys`` (complete runs only), the runs,
how many reached stage two, the median iteration of the switch, the median over runs of
the smallest and of the median change rate mc (seed paper Eq. 20) each run measured, the
mean IGD and HV, and the two-sided Wilcoxon rank-sum p of IGD and HV against the setting
that differs only in ``--reference`` (default: the paper's ``algorithm.threshold=0.001``
and ``algorithm.gap=20``). The numbers come from ``algorithm_summary`` (MGSAEA.summary), which
every MGSAEA-family run writes into its metrics.json; runs of other algorithms (e.g. the
PlatEMO-parity sweeps of C-TSEA, CMOES, SSDE, KTS, PEA) get IGD, HV and their tests, with
the stage columns ``n/a``:

    python experiments/stage_study.py multirun/platemo_parity_cmoes --rescore --compact \
        --keys problem,algorithm.reference,algorithm.switch_keeps_populations \
        --reference algorithm.reference=tmopt,algorithm.switch_keeps_populations=False

``--compact``: one "setting" column instead of the keys after the first, naming the keys
whose value differs from ``--reference`` ("tmopt defaults" where none does).
``--paired``: two more columns, the Wilcoxon signed-rank p of IGD and HV against the
reference setting over the seeds both have (the same seed gives both settings the same
initial sample, so the seeds pair).
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from tmopt.reporting.runs import COMPLETE, discover_runs
from tmopt.reporting.stats import fmt_p, rank_sum, signed_rank


def _median(values: list) -> str:
    vals = [v for v in values if v is not None]
    return f"{np.median(vals):.3g}" if vals else "n/a"


def _mean(values: list) -> str:
    vals = [v for v in values if v is not None]
    return f"{np.mean(vals):.4f} ± {np.std(vals, ddof=1):.4f}" if len(vals) > 1 else (
        f"{vals[0]:.4f}" if vals else "n/a")


def stage_rows(sweep: Path, keys: list[str], reference: dict[str, str],
               rescore: bool = False, paired: bool = False) -> list[list[str]]:
    """One row per setting: key values, runs, stage-two runs, switch iteration, mc, IGD, HV
    and their p against the reference setting (``rescore``: IGD and HV recomputed from
    the archives against today's fronts, as ``collect --rescore``; ``paired``: then the
    signed-rank p of IGD and HV over the seeds both settings ran)."""
    from tmopt.reporting.anytime import rescored

    groups: dict[tuple, list[dict]] = defaultdict(list)
    for run in discover_runs(sweep):
        run = rescored(run) if rescore else run
        if run.status == COMPLETE:
            groups[tuple(run.value(k) for k in keys)].append(run.metrics)
    rows = []
    for setting in sorted(groups):
        runs = groups[setting]
        ref = tuple(reference.get(k, v) for k, v in zip(keys, setting))
        theirs = groups.get(ref) if ref != setting else None
        summaries = [m["algorithm_summary"] for m in runs
                     if "stage_reached" in (m.get("algorithm_summary") or {})]
        mc = [s["mc"] for s in summaries if s["mc"]]
        tests = [fmt_p(rank_sum([m.get(q) for m in runs], [m.get(q) for m in theirs]))
                 if theirs else "" for q in ("igd", "hv")]
        rows.append([*setting, str(len(runs)),
                     str(sum(s["stage_reached"] >= 2 for s in summaries)) if summaries
                     else "n/a",
                     _median([s["switch_iteration"] for s in summaries]),
                     _median([m["min"] for m in mc]), _median([m["median"] for m in mc]),
                     _mean([m.get("igd") for m in runs]), tests[0],
                     _mean([m.get("hv") for m in runs]), tests[1]])
        if paired:
            rows[-1] += [fmt_p(signed_rank(_by_seed(runs, q), _by_seed(theirs, q)))
                         if theirs else "" for q in ("igd", "hv")]
    return rows


def _by_seed(runs: list[dict], metric: str) -> dict:
    """``metric`` of each run keyed by its seed."""
    return {m.get("seed"): m.get(metric) for m in runs}


def _compact(header: list[str], rows: list[list[str]], keys: list[str],
             reference: dict[str, str]) -> tuple[list[str], list[list[str]]]:
    """The key columns after the first folded into one "setting" column (the keys whose
    value differs from ``reference``), rows ordered: defaults, single changes, the rest."""
    out = []
    for row in rows:
        off = [f"{k.split('.')[-1]}={v}" for k, v in zip(keys[1:], row[1:len(keys)])
               if k in reference and str(v) != reference[k]]
        out.append([row[0], ", ".join(off) or "tmopt defaults", *row[len(keys):]])
    out.sort(key=lambda r: (r[0], r[1] != "tmopt defaults", "reference=" in r[1], r[1]))
    return [header[0], "setting", *header[len(keys):]], out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("sweep", type=Path)
    ap.add_argument("--keys", default="problem,algorithm.threshold",
                    help="comma list of setting keys (group choices or dotted config keys)")
    ap.add_argument("--reference", default="algorithm.threshold=0.001,algorithm.gap=20",
                    help="KEY=VALUE,... of the setting each row is tested against")
    ap.add_argument("--rescore", action="store_true",
                    help="recompute IGD and HV from the archives against today's fronts")
    ap.add_argument("--compact", action="store_true",
                    help="one 'setting' column: the keys (after the first) off --reference")
    ap.add_argument("--paired", action="store_true",
                    help="add the signed-rank p of IGD and HV, paired by seed")
    args = ap.parse_args(argv)
    if not args.sweep.is_dir():
        print(f"stage_study: sweep folder {args.sweep} does not exist", file=sys.stderr)
        return 2
    keys = args.keys.split(",")
    reference = dict(item.split("=", 1) for item in args.reference.split(","))
    header = [*keys, "runs", "stage two", "switch iteration (median)", "min mc (median)",
              "median mc (median)", "IGD", "p (IGD)", "HV", "p (HV)",
              *(["p paired (IGD)", "p paired (HV)"] if args.paired else [])]
    rows = stage_rows(args.sweep, keys, reference, args.rescore, args.paired)
    if rows and all(row[len(keys) + 1] == "n/a" for row in rows):  # no MGSAEA-family run
        stage_columns = set(range(len(keys) + 1, len(keys) + 5))
        header, *rows = ([c for i, c in enumerate(r) if i not in stage_columns]
                         for r in (header, *rows))
    if args.compact:
        header, rows = _compact(header, rows, keys, reference)
    print("| " + " | ".join(header) + " |")
    print("|" + " --- |" * len(header))
    for row in rows:
        print("| " + " | ".join(row) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
