"""The tool's two family-wise levels against the issue's false-alarm budget (issue 26:
<= 2 % of clean recordings; docs/mismatch.md 9.36).

At 0.01 each, the catalogue's Holm test and the locate step, with the smaller tests that
spend their levels on top, summed past the budget, and the benchmark agreed: 31/1367
clean flight-like recordings raised something, every alarm just under its level.  A
paired test written before its rows were read halved both (0.005): clean alarms 2/128
against 5/128, no attribution or out-of-catalogue success lost on 150 never-seen
recordings, one wrong name fewer.
"""

from __future__ import annotations

from tmopt.mismatch import calibration as cal
from tmopt.mismatch.diagnose import Evaluation, Settings, _significant
from tmopt.mismatch.effects import Candidate

ISSUE_BUDGET = 0.02


def _ev(effect: str, channel: str, p_holm: float) -> Evaluation:
    """A first-step evaluation with the numbers :func:`_significant` reads."""
    return Evaluation(Candidate(effect, channel, "equation", ["a"], ["m s^-2"]), 25.0, 1,
                      20000, p_holm, p_holm)  # fmt: skip


def test_the_defaults_are_the_levels_the_paired_test_chose():
    s = Settings()
    assert (s.alpha, s.locate_alpha) == (cal.FAMILY_ALPHA, cal.LOCATE_ALPHA) == (0.005, 0.005)


def test_single_names_raised_on_clean_records_just_under_one_percent_are_not_named():
    """Single names raised on clean records at the old level: Holm p 0.0056 and 0.0078,
    the ends of the three on 350000 (an ambiguous drift, an accelerometer cross-talk, a
    2e-4 gain; docs/mismatch.md 9.36), and kernel 22045's ambiguous drift at 0.0076 (the
    calibration set, 9.15 (c)).  A curved force at p 0.0020 (kernel 350022) is still
    reported -- the level is halved, not the tool silenced."""
    alpha = Settings().alpha
    raised = [_ev("bias_drift", "x2", 0.0078), _ev("bias_drift", "x1", 0.0076),
              _ev("actuation_gain", "x1", 0.0056)]  # fmt: skip
    curved = _ev("bias_drift", "y1", 0.0020)
    assert _significant(raised, alpha) == []
    assert _significant([curved], alpha) == [curved]


def test_the_levels_spent_on_a_clean_record_fit_the_budget():
    """Bonferroni's union of the levels every clean record meets: the catalogue's family
    (FAMILY_ALPHA), the joint stage (calibrated to FAMILY_ALPHA / 2 per family, two
    families: docs/mismatch.md 9.9) and the locate step (LOCATE_ALPHA, split inside it
    between the two residual groups and their band and time tests,
    :func:`tmopt.mismatch.diagnose._locate_state`).  At 0.01 each it was 0.03, past the
    issue's 2 %."""
    spent = cal.FAMILY_ALPHA + 2 * cal.FAMILY_ALPHA / 2 + cal.LOCATE_ALPHA
    assert spent <= ISSUE_BUDGET, spent
