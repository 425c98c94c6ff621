"""Joint stage (issue 26, item 5): re-test the best candidates the greedy selection left
out, with the coloured noise model re-estimated *under the alternative*.  Opt-in
(``Settings(joint=True)``, ``--joint``): on never-seen recordings five of its six
additions were wrong, its null being calibrated on clean recordings only
(docs/mismatch.md 9.7, "Ninth run").

Why.  The selection (:mod:`tmopt.mismatch.diagnose`) estimates the equation group's
noise spectrum from the current residual, i.e. under the null "no further effect".  An
effect not yet fitted is part of that residual: its power raises the smoothed spectrum in
its own band and is whitened down with it (a bias drift beside a 0.2 s actuation delay:
GLR 14.7 under the null's noise, 92.6 under the alternative's; docs/mismatch.md 9.7,
"Seventh round").  Pairs of effects are where this bites: the first effect is fitted,
the second one's statistic is computed against a spectrum that still holds it.

The statistic.  For a candidate with columns ``X`` added to the fitted columns ``X0``,
the spectrum is profiled at the alternative: the noise model ``S1`` is re-estimated from
the residual of the fit with ``X`` (feasible GLS iterated as the selection does,
:func:`tmopt.mismatch.diagnose._fit_eq`), and the likelihood ratio of ``X`` is computed
with both fits whitened by ``S1`` -- ``L = n log(RSS0/RSS1)`` (the Gaussian LR with the
scale profiled; the same statistic as the selection's, with the alternative's spectrum in
place of the null's).  This is the generalised LR with the nuisance spectrum at its
alternative estimate (the estimate that does not absorb the candidate); under "no effect"
it is no longer chi^2: where a candidate's fit removes noise power (a drift-like column
on 1/f^2 acceleration noise takes the random walk's "ramp"), ``S1`` is lowered in that
band and ``L`` inflated.  So its null distribution is measured, per family, on clean
flight-like recordings of both simulators (experiments/mismatch_calibration.py
``--realistic --joint``; docs/mismatch.md 9.9):

* ``drift``: ``bias_drift``, ``stiffness_drift`` -- slow columns, inflated by 1/f^2 noise;
* ``other``: every other equation-group catalogue effect that is linear in its
  parameters (gains, delays, couplings, cubic stiffness, rotation, readout scale ...).

Each family's inflation ``c_f`` (:data:`INFLATION`) is the calibration's; a candidate is
significant when ``p = min(1, m * trials * chi2_sf(L / c_f, dof)) < alpha`` with ``m``
the catalogue's multiplicity (:func:`trials`: the screen picks the re-tested ones from
every candidate the selection tested; ``trials`` the candidate's own search factor, as
in the selection), and its
``L / c_f - (dof + searched) ln n > 0`` (BIC, as the selection).  The best such candidate
(largest BIC gain) is added to the model and the stage repeats (at most
:data:`MAX_ADDED` additions); the selection's rules then judge it as any selected
effect (ambiguity band among the stage's significant candidates, backward elimination,
weak names, shape check).

Candidates re-tested (:func:`screened`): not selected, of the equation group, not
profiled (a searched form is the selection's business), not an accelerometer twin,
significant alone at the tool's level but not after the catalogue-wide correction, the
:data:`TOP` strongest by null GLR; and when the selection chose nothing, also the pairs
of the :data:`PAIR_TOP` strongest (a pair's columns together; each member is then
judged by the selection's rules).  Every re-test is recorded in the report's
``data_used.joint_stage``; what the stage adds is said in its ``notes``.
"""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import dataclass

from scipy import stats

from tmopt.mismatch import calibration as cal
from tmopt.mismatch.effects import EFFECTS

__all__ = ["DRIFT_LIKE", "WITNESS_DRIVEN", "INFLATION", "TOP", "PAIR_TOP", "MAX_ADDED", "family",
           "alt_statistics", "JointTest", "extend", "screened", "pair_indices", "trials",
           "retest", "eligible", "alt_glr"]

#: Effects whose columns are slow in time: their null distribution under the
#: alternative's noise is inflated by the 1/f^2 acceleration noise (random-walk ramps).
DRIFT_LIKE = frozenset(name for name, e in EFFECTS.items() if e.slow_in_time)

#: Effects whose columns come from witness channels outside the TM loop (rotation
#: coupling): their own family, calibrated on clean recordings whose witnesses move
#: (``calibration.WITNESS_REFIT_INFLATION``, the selection's factor for them too).
WITNESS_DRIVEN = frozenset(name for name, e in EFFECTS.items() if e.witness_driven)

#: Per family, the factor by which ``L`` under the alternative's noise exceeds chi^2 in
#: the upper tail on clean flight-like recordings (calibrated: docs/mismatch.md 9.9; the
#: witness family 9.28 -- the clean recordings of 9.9 had still witnesses, so a rotation
#: column was never tested there).
INFLATION = {**cal.JOINT_INFLATION, "witness": cal.WITNESS_REFIT_INFLATION}

#: Candidates re-tested per recording (by null GLR), of them paired when nothing is
#: selected, and additions at most.
TOP, PAIR_TOP, MAX_ADDED = 6, 4, 2


def family(effect: str) -> str:
    if effect in DRIFT_LIKE:
        return "drift"
    return "witness" if effect in WITNESS_DRIVEN else "other"


@dataclass
class JointTest:
    """One re-tested candidate (or pair): ``evals`` the selection's evaluations of its
    members, ``glr_null`` their sum of null GLRs, ``glr_alt`` the statistic under the
    alternative's noise, ``dof``, ``trials`` (product of the members' search factors),
    ``n_searched``, ``n_obs``; ``p_value`` and ``dbic`` after :func:`score`."""

    evals: list
    glr_null: float
    glr_alt: float
    dof: int
    trials: float
    n_searched: int
    n_obs: int
    family: str
    p_value: float = 1.0
    dbic: float = -math.inf

    @property
    def keys(self) -> list[str]:
        return [e.candidate.key for e in self.evals]

    def score(self, m: int, inflation: dict | None = None) -> JointTest:
        """p-value (Bonferroni over ``m`` re-tests and the members' searches) and BIC gain
        of the family-deflated statistic."""
        c = (INFLATION if inflation is None else inflation)[self.family]
        lam = self.glr_alt / c
        self.p_value = min(1.0, m * self.trials * float(stats.chi2.sf(lam, self.dof)))
        self.dbic = lam - (self.dof + self.n_searched) * math.log(self.n_obs)
        return self

    def significant(self, alpha: float = cal.FAMILY_ALPHA) -> bool:
        return self.p_value < alpha and self.dbic > 0


def trials(n_tests: int, size: int) -> int:
    """Bonferroni factor of a re-test of ``size`` candidates: the stage re-tests
    hypotheses the selection tested over the whole catalogue of ``n_tests`` candidates
    (the screen and :data:`TOP` pick them by the data), so it carries their multiplicity:
    ``n_tests`` for one, the number of pairs for two."""
    return math.comb(max(n_tests, size), size)


def eligible(ev) -> bool:
    c = ev.candidate
    model = EFFECTS.get(c.effect)
    return (c.group == "equation" and c.twin is None and model is not None
            and not model.profiled)


def screened(evals: list, screen: float, n_tests: int = 1, top: int = TOP) -> list:
    """The candidates the stage re-tests: eligible, significant alone at ``screen``
    (their own p-value, trials factor included, before the catalogue-wide correction) but
    not after it (``n_tests`` p >= screen: one the selection would take is its business --
    left out only because it was banned as beyond physics), the ``top`` strongest by null
    GLR.  ``screen`` >= 1: no screen."""
    keep = [e for e in evals if eligible(e) and
            (screen >= 1 or e.p_value < screen <= n_tests * e.p_value)]  # fmt: skip
    return sorted(keep, key=lambda e: -e.glr)[:top]


def pair_indices(keys: list[str], pair_top: int = PAIR_TOP) -> list[tuple[int, int]]:
    """Pairs of the ``pair_top`` first of the re-tested candidates (two variants of one
    effect on one channel are no pair), in the order :func:`alt_statistics` tests them."""
    n = min(len(keys), pair_top)
    return [(i, j) for i, j in itertools.combinations(range(n), 2) if keys[i] != keys[j]]


def alt_statistics(data, basis, state, evals: list, settings, pairs: bool,
                   screen: float | None = None, n_tests: int = 1) -> list[JointTest]:  # fmt: skip
    """The re-tests of the :func:`screened` ``evals`` (evaluations against ``state``, the
    selection's final model; ``screen`` defaults to ``settings.alpha``, 1 re-tests the
    :data:`TOP` strongest eligible ones), and of their pairs (:func:`pair_indices`)
    when ``pairs``."""
    cands = screened(evals, settings.alpha if screen is None else screen, n_tests)
    sets = [[e] for e in cands]
    if pairs:
        sets += [[cands[i], cands[j]]
                 for i, j in pair_indices([e.candidate.key for e in cands])]  # fmt: skip
    out = []
    for members in sets:
        cols = [c for e in members for c in e.candidate.columns]
        glr, n = alt_glr(data, basis, state, cols)
        fams = {family(e.candidate.effect) for e in members}
        out.append(JointTest(
            evals=members, glr_null=float(sum(e.glr for e in members)),
            glr_alt=glr, dof=len(cols),
            trials=math.prod(e.candidate.trials for e in members),
            n_searched=sum(e.candidate.n_searched for e in members), n_obs=n,
            family=max(fams, key=INFLATION.__getitem__)))  # fmt: skip
    return out


def alt_glr(data, basis, state, cols: list) -> tuple[float, int]:
    """GLR of the equation-group columns ``cols`` added to ``state``'s, both fits whitened
    by the spectrum re-estimated -- of ``state``'s kind -- from the residual of the fit
    *with* them (feasible GLS as the selection's, :func:`tmopt.mismatch.diagnose._fit_eq`):
    ``(L, n)`` with ``n`` the whitened residual's size."""
    from tmopt.mismatch.diagnose import _fit_eq, _Group
    from tmopt.mismatch.fit import equation_target, solve

    target = equation_target(data, basis)
    _, noise1 = _fit_eq(target, state.eq_cols + cols, state.red, data.layout, data.fs,
                        state.eq_noise.kind)  # fmt: skip
    fit0 = solve(target, state.eq_cols, noise1.whiten)
    group = _Group(None, state.eq_cols, fit0, noise1.whiten)
    return group.glr(cols), group.n


def _as_evaluation(test: JointTest, ev):
    """The selection's evaluation of a single re-test's candidate, carrying the stage's
    evidence (deflated statistic, its p-value and BIC gain) so the attribution rules
    (weak names, remainders, ambiguity) judge what the stage found."""
    from tmopt.mismatch.diagnose import Evaluation

    c = INFLATION[test.family]
    return Evaluation(copy.copy(ev.candidate), test.glr_alt / c, test.dof, test.n_obs,
                      test.p_value, test.p_value)  # fmt: skip


def retest(data, basis, others: list, ev, settings, m: int) -> JointTest:
    """One selected candidate re-tested given the ``others`` selected, with the noise
    model re-estimated under the alternative (the backward pass of the stage, and the
    re-judging of a weak name, :func:`tmopt.mismatch.diagnose.rejudged`), scored with
    ``m`` re-tests."""
    from tmopt.mismatch.diagnose import _rebuild

    state = _rebuild(data, basis, others, settings)
    return alt_statistics(data, basis, state, [ev], settings, pairs=False, screen=1.0)[0].score(m)


def extend(data, basis, state, selected: list, settings, tests, n_tests: int,
           banned: set[str]) -> tuple[list, object]:  # fmt: skip
    """The joint stage after the greedy selection and its backward pass (module
    docstring): returns the selection and state with what the stage added.  An effect it
    added must stay significant under the alternative's noise given every other selected
    effect, and the greedy selection's effects under the selection's own backward rule
    (:func:`tmopt.mismatch.diagnose._still_needed`); the first to fail is dropped, and so
    on (backward elimination)."""
    from tmopt.mismatch.diagnose import _add, _rebuild, _still_needed, events

    added: dict[int, int] = {}  # id of an evaluation the stage added -> its re-tests m
    for _ in range(MAX_ADDED):
        if len(events(selected)) >= settings.max_effects:
            break
        exclude = set(banned) | {ev.candidate.key for ev, _ in selected}
        evals = tests(state, exclude)
        jt = alt_statistics(data, basis, state, evals, settings, pairs=not selected,
                            n_tests=n_tests)  # fmt: skip
        for t in jt:
            t.score(trials(n_tests, len(t.evals)))
        data.usage.setdefault("joint_stage", []).extend(
            {"keys": t.keys, "family": t.family, "glr_null": t.glr_null, "glr_alt": t.glr_alt,
             "dof": t.dof, "p_value": t.p_value, "delta_bic": t.dbic} for t in jt)  # fmt: skip
        sig = [t for t in jt if t.significant(settings.alpha)]
        if not sig:
            break
        best = max(sig, key=lambda t: t.dbic)
        singles = {id(t.evals[0]): t for t in jt if len(t.evals) == 1}
        rivals = [t for t in sig if len(t.evals) == 1 and not set(t.keys) & set(best.keys)
                  and best.dbic - t.dbic < cal.AMBIGUOUS_DBIC]  # fmt: skip
        alts = [_as_evaluation(t, t.evals[0]) for t in rivals]
        for ev in best.evals:
            new = _as_evaluation(singles[id(ev)], ev)
            state = _add(data, basis, state, new, settings)
            selected = selected + [(new, alts)]
            added[id(new)] = trials(n_tests, 1)
    if not added:
        return selected, state
    if len(selected) < 2:
        _note(data, selected, added)
        return selected, state
    changed = True
    while changed and len(selected) > 1:
        changed = False
        chosen = [ev for ev, _ in selected]
        for i in reversed(range(len(chosen))):
            others = chosen[:i] + chosen[i + 1:]
            if id(chosen[i]) in added:
                ok = retest(data, basis, others, chosen[i], settings,
                            added[id(chosen[i])]).significant(settings.alpha)  # fmt: skip
            else:
                ok = _still_needed(data, basis, chosen, i, settings, n_tests)
            if not ok:
                selected = selected[:i] + selected[i + 1:]
                changed = True
                break
    _note(data, selected, added)
    return selected, _rebuild(data, basis, [ev for ev, _ in selected], settings)


def _note(data, selected: list, added: dict) -> None:
    """Say in the report's notes which effects the stage added (once per diagnosis)."""
    for ev, _ in selected:
        if id(ev) in added:
            note = (f"joint stage: {ev.candidate.key} found with the noise model re-estimated "
                    f"under the alternative (statistic {ev.glr:.1f} after its family's "
                    f"inflation, p = {ev.p_value:.2g})")
            if note not in data.notes:
                data.notes.append(note)
