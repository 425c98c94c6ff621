"""Two sweeps side by side, setting by setting: does sweep B differ from sweep A?

``python -m tmopt.collect`` tests every setting against a reference *algorithm*; this
answers the other question — the same algorithm under two values of a key that is not
the algorithm (surrogate, preset, code version), each value in its own sweep folder.
"""

from __future__ import annotations

from pathlib import Path

from tmopt.reporting.runs import COMPLETE, RunRecord, deduplicate, discover_runs, group_runs
from tmopt.reporting.stats import fmt_mean_std, fmt_p, mark, rank_sum
from tmopt.reporting.tables import to_markdown

#: metric key -> lower is better
SUITE_METRICS = {"igd": True, "hv": False}


def by_setting(sweep: Path, keys: list[str]) -> dict[tuple, list[RunRecord]]:
    """Complete runs of ``sweep`` (each configuration and seed once, as collect counts
    them) grouped by their values of ``keys``."""
    if not Path(sweep).is_dir():
        raise FileNotFoundError(f"sweep folder {sweep} does not exist")
    runs, _ = deduplicate([r for r in discover_runs(sweep) if r.status == COMPLETE])
    return group_runs(runs, keys)


def _values(runs: list[RunRecord], key: str) -> list[float | None]:
    return [(r.metrics or {}).get(key) for r in runs]


def compare_sweeps(sweep_a: Path, sweep_b: Path, keys: list[str],
                   labels: tuple[str, str] = ("A", "B"),
                   metrics: dict[str, bool] | None = None) -> str:
    """Markdown table: per setting of ``keys`` found in both sweeps, each metric's
    mean ± std in A and in B and the two-sided Wilcoxon rank-sum p-value of B against A
    (``+``/``-``/``=``: B better / worse / no significant difference at 0.05)."""
    metrics = metrics or SUITE_METRICS
    a, b = by_setting(sweep_a, keys), by_setting(sweep_b, keys)
    common = sorted(set(a) & set(b))
    if not common:
        raise ValueError(f"no setting of keys {keys} has complete runs in both sweeps")
    head = [*keys, "runs"]
    for m in metrics:
        head += [f"{m} {labels[0]}", f"{m} {labels[1]}", f"p ({m})"]
    body = []
    for setting in common:
        cells = [*(value for _, value in setting), f"{len(a[setting])} / {len(b[setting])}"]
        for m, lower in metrics.items():
            xa, xb = _values(a[setting], m), _values(b[setting], m)
            p = rank_sum(xb, xa)
            cells += [fmt_mean_std(xa), fmt_mean_std(xb),
                      f"{fmt_p(p)} {mark(xb, xa, p, lower_is_better=lower)}".strip()]
        body.append(cells)
    return to_markdown(head, body)
