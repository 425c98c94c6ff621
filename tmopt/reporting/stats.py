"""Summaries over seeds: mean ± std, and the Wilcoxon rank-sum test against a reference.

The test is the two-sided Wilcoxon rank-sum test, computed as the equivalent
Mann-Whitney U test (``scipy.stats.mannwhitneyu``, ``method="auto"``: the exact
distribution for small samples without ties, the normal approximation with tie
correction otherwise). PlatEMO and the evolutionary-computation literature report the
same test; with 5 seeds per side the smallest attainable p-value is 2/252 = 0.0079.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.stats import mannwhitneyu

#: Significance level of the +/-/= marks.
ALPHA = 0.05


def finite(values: Sequence[float | None]) -> np.ndarray:
    """The finite values of a sequence (None / NaN / inf dropped)."""
    arr = np.array([np.nan if v is None else float(v) for v in values], dtype=float)
    return arr[np.isfinite(arr)]


def mean_std(values: Sequence[float | None]) -> tuple[float, float, int]:
    """Mean, sample standard deviation (ddof 1; NaN for one value) and count of finite values."""
    v = finite(values)
    if len(v) == 0:
        return math.nan, math.nan, 0
    std = float(v.std(ddof=1)) if len(v) > 1 else math.nan
    return float(v.mean()), std, len(v)


def fmt_number(x: float, sci: bool | None = None) -> str:
    """Four significant digits; scientific notation for very small or large magnitudes."""
    if x is None or not math.isfinite(x):
        return "n/a"
    if sci is None:
        sci = x != 0 and not 1e-3 <= abs(x) < 1e5
    if not sci and float(x).is_integer():
        return str(int(x))
    return f"{x:.3g}" if sci else f"{x:.4g}" if abs(x) < 100 else f"{x:.1f}"


def fmt_mean_std(values: Sequence[float | None], sci: bool | None = None) -> str:
    """``mean ± std`` (``mean`` alone for one value; ``n/a`` for none)."""
    mean, std, n = mean_std(values)
    if n == 0:
        return "n/a"
    if sci is None:
        sci = mean != 0 and not 1e-3 <= abs(mean) < 1e5
    if n == 1:
        return fmt_number(mean, sci)
    return f"{fmt_number(mean, sci)} ± {_fmt_spread(std, sci)}"


def _fmt_spread(std: float, sci: bool) -> str:
    """A standard deviation to 2-3 significant digits (it is itself uncertain)."""
    if sci:
        return f"{std:.2g}"
    return f"{std:.1f}" if std >= 100 else f"{std:.3g}"


def rank_sum(a: Sequence[float | None], b: Sequence[float | None]) -> float:
    """Two-sided Wilcoxon rank-sum p-value of ``a`` vs ``b`` (NaN if a side has < 2 values)."""
    x, y = finite(a), finite(b)
    if len(x) < 2 or len(y) < 2:
        return math.nan
    if np.ptp(np.concatenate([x, y])) == 0:
        return 1.0  # all equal: no evidence of a difference (scipy would warn)
    return float(mannwhitneyu(x, y, alternative="two-sided", method="auto").pvalue)


def mark(a: Sequence[float | None], b: Sequence[float | None], p: float,
         lower_is_better: bool = True) -> str:
    """``+`` (a significantly better than b), ``-`` (worse), ``=`` (no significant difference),
    ``""`` when untestable; better/worse by the medians, as in PlatEMO's tables."""
    if not math.isfinite(p):
        return ""
    if p >= ALPHA:
        return "="
    better = np.median(finite(a)) < np.median(finite(b))
    return "+" if better == lower_is_better else "-"


def fmt_p(p: float) -> str:
    if not math.isfinite(p):
        return "n/a"
    return f"{p:.3f}" if p >= 1e-3 else f"{p:.1e}"
