"""The selection's pair step (issue 26, item 5; stop 42, docs/mismatch.md 9.18):
:mod:`tmopt.mismatch.pairs`, called by :func:`tmopt.mismatch.diagnose._select` where no
single candidate is significant.

Foreign 160106 (the seventeenth benchmark run's, already read: the rule was designed on
it) holds a bias drift and a stiffness drift on x1, each SNR 40 alone, that hide each
other: single GLRs 9.4 and 4.3, 42.8 together.  Its rates are measured on clean
calibration recordings and a never-seen benchmark draw."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy import stats

from tmopt.mismatch import diagnose as dgn
from tmopt.mismatch import joint, pairs
from tmopt.mismatch.report import build_report

from . import benchmark_cases


def _recording(backend: str, seed: int):
    return benchmark_cases.recording(backend, seed)


@functools.cache
def _diagnosed(backend: str, seed: int, with_pairs: bool):
    from tmopt.mismatch.fit import data_from_recording

    return dgn.diagnose(data_from_recording(_recording(backend, seed)),
                        dgn.Settings(pairs=with_pairs))  # fmt: skip


def test_two_drifts_that_hide_each_other_are_found_together():
    """Without the pair step nothing is reported; with it both drifts are named, each
    with its statistic beside the other (33.4 and 38.5), and the notes say how."""
    assert not _diagnosed("foreign", 160106, False).mismatch_detected
    dg = _diagnosed("foreign", 160106, True)
    keys = sorted(ev.candidate.key for ev, _ in dg.selected)
    assert keys == ["bias_drift[x1]", "stiffness_drift[x1]"]
    assert all(ev.glr > 25 and ev.dbic > 6 for ev, _ in dg.selected)
    rep = build_report(dg)
    assert sorted(e["name"] for e in rep["effects"]) == ["bias_drift", "stiffness_drift"]
    assert not rep["ambiguous"] and not rep["unexplained"]
    assert any(n.startswith("pair search: ") for n in rep["notes"])


def test_the_pair_statistics_match_a_direct_fit_of_each_pair():
    """The Gram-matrix shortcut against the selection's own GLR of the two columns
    (``_Group.glr``, a least-squares fit) on the recording's first step, every pair; the
    Bonferroni factor is the catalogue's pairs."""
    dg = _diagnosed("foreign", 160106, False)
    group = dgn.residual_groups(dg.data, dg.before)["equation"]
    evals = dg.steps[0]
    tests = pairs.pair_tests(group, evals, len(evals))
    n_elig = sum(joint.eligible(e) for e in evals)
    assert n_elig > 20 and len(tests) == math.comb(n_elig, 2)
    rng = np.random.default_rng(0)
    for t in rng.choice(tests, 25, replace=False):
        cols = t.first.candidate.columns + t.second.candidate.columns
        assert t.glr == pytest.approx(group.glr(cols), rel=1e-6, abs=1e-6)
        alone = group.glr(t.second.candidate.columns)
        assert t.given[0] == pytest.approx(t.glr - alone, rel=1e-6, abs=1e-6)
        assert t.p_value == pytest.approx(
            min(1.0, math.comb(len(evals), 2) * stats.chi2.sf(t.glr, t.dof)))
    [best] = [t for t in tests
              if set(t.keys) == {"bias_drift[x1]", "stiffness_drift[x1]"}]  # fmt: skip
    assert best.glr > 40 and best.p_value < 1e-4


def test_a_strong_single_with_a_passenger_is_no_pair():
    """A pair is significant only if each member is needed beside the other at the
    catalogue's bar: a pair whose second member adds nothing is refused though its
    statistic is large."""
    dg = _diagnosed("foreign", 160106, False)
    group = dgn.residual_groups(dg.data, dg.before)["equation"]
    evals = dg.steps[0]
    t = next(t for t in pairs.pair_tests(group, evals, len(evals))
             if set(t.keys) == {"bias_drift[x1]", "stiffness_drift[x1]"})  # fmt: skip
    assert pairs.significant([t], 0.01, len(evals)) == [t]
    passenger = pairs.PairTest(t.first, t.second, t.glr, t.dof, t.n_obs, t.p_value,
                               (t.given[0], 0.5))  # fmt: skip
    assert pairs.significant([passenger], 0.01, len(evals)) == []


def test_the_pair_step_needs_room_for_two_effects():
    """With ``max_effects`` 1 a pair cannot be added: nothing is selected."""
    from tmopt.mismatch.fit import data_from_recording

    dg = dgn.diagnose(data_from_recording(_recording("foreign", 160106)),
                      dgn.Settings(max_effects=1))  # fmt: skip
    assert not dg.selected
