"""Pair search of the selection (issue 26, item 5: "find weak effects in pairs with a
joint search, not one at a time").

Why.  The stepwise selection (:func:`tmopt.mismatch.diagnose._select`) adds one candidate
at a time.  Two effects whose columns are nearly collinear can hide each other there: each
one's single test sees the sum projected on its own column, and where their signatures
have opposite signs that projection is small.  A bias drift (a force ramp) beside a
stiffness drift on the same axis (``k(t) x`` holds a ramp where the axis sits off zero):
foreign 160106, each at SNR 40 alone, single GLRs 9.4 and 4.3 -- neither significant after
the catalogue's multiplicity -- and 42.8 together (2 dof).  Nothing was reported.

The test.  When no single candidate is significant, every pair of *eligible* candidates
(:func:`tmopt.mismatch.joint.eligible`: the equation group's catalogue effects linear in
their parameters, without an accelerometer twin -- one group, one likelihood) is fitted
together against the current model under the *null's* noise model, the selection's own
statistic (``n log(RSS0 / RSS1)``, :class:`tmopt.mismatch.diagnose._Group`), computed for
all pairs from one Gram matrix.  A pair is significant when

* ``p = min(1, C(n_tests, 2) chi2_sf(L, dof)) < alpha`` -- Bonferroni over every pair of
  the catalogue the step tested (:func:`tmopt.mismatch.joint.trials`), and its BIC gain
  is positive; and
* each member is needed beside the other: its conditional statistic (the pair's less the
  partner's alone) has ``n_tests chi2_sf < alpha`` -- the bar of
  :func:`tmopt.mismatch.diagnose._still_needed` -- so a strong single with a passenger is
  no pair (it would have been selected alone).

The best such pair (largest BIC gain) is added, once per selection (:data:`MAX_PAIRS`),
and the selection goes on; its members are then judged by the selection's rules (backward
pass, weak names, shape checks).  Pairs within ``AMBIGUOUS_DBIC`` of it are the members'
rivals.  Under the null's spectrum (not the alternative's, as the opt-in joint stage,
:mod:`tmopt.mismatch.joint`, whose additions were wrong five times in six) the statistic
is the selection's, whose false alarms are calibrated on clean flight-like recordings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from tmopt.mismatch import calibration as cal
from tmopt.mismatch import joint

__all__ = ["MAX_PAIRS", "PairTest", "pair_tests", "significant", "best_pair"]

#: Pairs the search may add per selection.
MAX_PAIRS = 1


@dataclass
class PairTest:
    """Two candidates fitted together: their evaluations (against the state searched),
    the pair's statistic and each member's beside the other."""

    first: object  # Evaluation
    second: object  # Evaluation
    glr: float
    dof: int
    n_obs: int
    p_value: float  # Bonferroni over the catalogue's pairs
    given: tuple[float, float]  # (first beside second, second beside first)

    @property
    def dbic(self) -> float:
        return self.glr - self.dof * math.log(self.n_obs)

    @property
    def keys(self) -> tuple[str, str]:
        return self.first.candidate.key, self.second.candidate.key


def pair_tests(group, evals: list, n_tests: int) -> list[PairTest]:
    """Every pair of the :func:`tmopt.mismatch.joint.eligible` ``evals`` (two variants of
    one key are no pair) tested together in ``group`` (a ``diagnose._Group`` of the
    state the evaluations were made against).  ``n_tests``: the step's candidates, whose
    pairs are the Bonferroni factor."""
    cands = [e for e in evals if joint.eligible(e)]
    if len(cands) < 2:
        return []
    cols, spans, start = [], [], 0
    for e in cands:
        cols += e.candidate.columns
        spans.append(np.arange(start, start + len(e.candidate.columns)))
        start += len(e.candidate.columns)
    xp = group.perp(cols)  # (n, columns): whitened, the fitted design projected out
    norm = np.linalg.norm(xp, axis=0)
    xp = xp / np.where(norm > 0, norm, 1.0)  # unit columns: the Gram's conditioning is the
    b, gram = xp.T @ group.r0, xp.T @ xp  # pair's own, not the units' (1e-16 m s^-3 ...)
    alone = [_drop(b, gram, s) for s in spans]
    factor = joint.trials(n_tests, 2)
    out = []
    for i in range(len(cands)):
        for j in range(i + 1, len(cands)):
            if cands[i].candidate.key == cands[j].candidate.key:
                continue
            idx = np.concatenate([spans[i], spans[j]])
            lam = _glr(group, _drop(b, gram, idx))
            dof = idx.size
            p = min(1.0, factor * float(stats.chi2.sf(lam, dof)))
            given = (lam - _glr(group, alone[j]), lam - _glr(group, alone[i]))
            out.append(PairTest(cands[i], cands[j], lam, dof, group.n, p, given))
    return out


def _drop(b: np.ndarray, gram: np.ndarray, idx: np.ndarray) -> float:
    """RSS removed by the columns ``idx`` (least squares on the projected columns)."""
    bi = b[idx]
    return float(bi @ np.linalg.pinv(gram[np.ix_(idx, idx)]) @ bi)


def _glr(group, drop: float) -> float:
    return float(group.n * math.log(group.rss0 / max(group.rss0 - drop, 1e-300)))


def significant(tests: list[PairTest], alpha: float, n_tests: int) -> list[PairTest]:
    """The pairs significant after the pairs' Bonferroni, with a positive BIC gain, each
    member needed beside the other at the catalogue's bar."""
    def needed(t: PairTest, k: int) -> bool:
        ev = (t.first, t.second)[k]
        return n_tests * float(stats.chi2.sf(t.given[k], len(ev.candidate.columns))) < alpha

    return [t for t in tests if t.p_value < alpha and t.dbic > 0
            and needed(t, 0) and needed(t, 1)]  # fmt: skip


def best_pair(group, evals: list, alpha: float, n_tests: int):
    """The selection's pair step: ``[(member evaluation, rivals), (..., ...)]`` for the
    best significant pair (largest BIC gain), or None.  Each member's evaluation carries
    its statistic *beside its partner* (what it adds to the model with the partner in),
    and its p-value at the catalogue's bar; its rivals are the members of the pairs within
    ``AMBIGUOUS_DBIC`` that could take its place (the partner kept, or both replaced)."""
    from tmopt.mismatch.diagnose import Evaluation

    sig = significant(pair_tests(group, evals, n_tests), alpha, n_tests)
    if not sig:
        return None
    best = max(sig, key=lambda t: t.dbic)
    near = [t for t in sig if t is not best and best.dbic - t.dbic < cal.AMBIGUOUS_DBIC]
    out = []
    for k, ev in enumerate((best.first, best.second)):
        partner = (best.second, best.first)[k].candidate.key
        dof = len(ev.candidate.columns)
        p = float(stats.chi2.sf(best.given[k], dof))
        member = Evaluation(ev.candidate, best.given[k], dof, best.n_obs, p,
                            min(1.0, n_tests * p))  # fmt: skip
        rivals = []
        for t in near:
            if ev.candidate.key in t.keys:
                continue  # the same member with another partner: the partner's rival
            rivals += [e for e in (t.first, t.second) if e.candidate.key != partner]
        out.append((member, _unique(rivals)))
    return out


def _unique(evals: list) -> list:
    seen, out = set(), []
    for e in evals:
        if e.candidate.key not in seen:
            seen.add(e.candidate.key)
            out.append(e)
    return out
