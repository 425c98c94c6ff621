"""Summaries over seeds: mean ± std, and the Wilcoxon rank-sum test against a reference;
across problems: the Friedman test with Holm's post-hoc (Demšar 2006).

The test is the two-sided Wilcoxon rank-sum test, computed as the equivalent
Mann-Whitney U test (``scipy.stats.mannwhitneyu``, ``method="auto"``: the exact
distribution for small samples without ties, the normal approximation with tie
correction otherwise). PlatEMO and the evolutionary-computation literature report the
same test; with 5 seeds per side the smallest attainable p-value is 2/252 = 0.0079.
Where two settings share their seeds (the same seed gives the same initial sample), the
paired alternative is the Wilcoxon signed-rank test over the seeds both have
(:func:`signed_rank`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import mannwhitneyu, wilcoxon

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


def signed_rank(a: dict[int, float | None], b: dict[int, float | None]) -> float:
    """Two-sided Wilcoxon signed-rank p-value of ``a`` vs ``b`` paired by key (the seed):
    the keys with a finite value on both sides (``scipy.stats.wilcoxon``, exact for small
    samples without ties; NaN if fewer than 2 pairs, 1.0 if every pair is equal)."""
    keys = sorted(k for k in a.keys() & b.keys()
                  if all(v is not None and math.isfinite(v) for v in (a[k], b[k])))
    if len(keys) < 2:
        return math.nan
    diff = np.array([float(a[k]) - float(b[k]) for k in keys])
    if not diff.any():
        return 1.0  # no pair differs: no evidence of a difference (scipy would fail)
    return float(wilcoxon(diff, alternative="two-sided").pvalue)


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


# ---- across problems: Friedman test and Holm's post-hoc (Demšar, JMLR 7, 2006) ---------
def average_ranks(table: np.ndarray, lower_is_better: bool = True) -> np.ndarray:
    """Average rank of each algorithm (column) over the problems (rows), ties shared
    (Demšar 2006, Sec. 3.2.2: rank 1 the best on a problem, ties get the average rank)."""
    from scipy.stats import rankdata

    T = np.asarray(table, dtype=float)
    ranks = np.vstack([rankdata(row if lower_is_better else -row) for row in T])
    return ranks.mean(axis=0)


@dataclass(frozen=True)
class Friedman:
    """The Friedman test over N problems and k algorithms (Demšar 2006, Sec. 3.2.2).

    Attributes:
        ranks: (k,) average ranks.
        chi2: Friedman's statistic from the average ranks,
            ``12 N / (k (k+1)) (sum R_j^2 - k (k+1)^2 / 4)`` (no tie correction, as
            Demšar writes it); ``p_chi2`` from chi^2 with k-1 degrees of freedom.
        f: Iman and Davenport's ``(N-1) chi2 / (N (k-1) - chi2)``; ``p_f`` from F with
            (k-1, (k-1)(N-1)) degrees of freedom (Demšar recommends it: chi2 is
            conservative).
        n_problems, n_algorithms: N and k.
    """

    ranks: np.ndarray
    chi2: float
    p_chi2: float
    f: float
    p_f: float
    n_problems: int
    n_algorithms: int


def friedman(table: np.ndarray, lower_is_better: bool = True) -> Friedman:
    """Friedman test of an (N problems, k algorithms) table of one number per cell
    (infinite values rank last, e.g. the IGD of a run without a feasible design)."""
    from scipy.stats import chi2 as chi2_dist
    from scipy.stats import f as f_dist

    T = np.asarray(table, dtype=float)
    n, k = T.shape
    if n < 2 or k < 2 or np.any(np.isnan(T)):
        raise ValueError(f"the Friedman test needs a table of >= 2 problems x >= 2 "
                         f"algorithms without NaN (inf ranks last), got shape {T.shape}")
    R = average_ranks(T, lower_is_better)
    chi2 = 12 * n / (k * (k + 1)) * (float(np.sum(R ** 2)) - k * (k + 1) ** 2 / 4)
    denom = n * (k - 1) - chi2
    f = (n - 1) * chi2 / denom if denom > 0 else math.inf
    p_f = float(f_dist.sf(f, k - 1, (k - 1) * (n - 1))) if math.isfinite(f) else 0.0
    return Friedman(R, float(chi2), float(chi2_dist.sf(chi2, k - 1)), float(f), p_f, n, k)


def holm(p_values: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjusted p-values (Holm 1979; Demšar 2006, Sec. 3.2.2):
    sorted ``p_(1) <= ... <= p_(m)``, ``adj_(i) = max_{j <= i} min(1, (m - j + 1) p_(j))``;
    hypothesis i is rejected at level alpha when ``adj_i < alpha``."""
    p = np.asarray(p_values, dtype=float)
    m = len(p)
    order = np.argsort(p, kind="stable")
    adj = np.minimum(1.0, (m - np.arange(m)) * p[order])
    adj = np.maximum.accumulate(adj)
    out = np.empty(m)
    out[order] = adj
    return out


def post_hoc_vs_control(result: Friedman, control: int) -> tuple[np.ndarray, np.ndarray,
                                                                np.ndarray]:
    """Each algorithm against the control after a Friedman test (Demšar 2006, Sec. 3.2.2):
    ``z = (R_i - R_control) / sqrt(k (k+1) / (6 N))``, two-sided normal p-values and
    their Holm adjustment over the k-1 comparisons. Returns ``(z, p, p_holm)`` with NaN
    at the control's own index (negative z: better ranked than the control)."""
    from scipy.stats import norm

    k, n = result.n_algorithms, result.n_problems
    se = math.sqrt(k * (k + 1) / (6 * n))
    z = (result.ranks - result.ranks[control]) / se
    p = 2 * norm.sf(np.abs(z))
    others = [i for i in range(k) if i != control]
    p_holm = np.full(k, np.nan)
    p_holm[others] = holm(p[others])
    z[control], p[control] = np.nan, np.nan
    return z, p, p_holm
