"""A force line between two grid frequencies of the longest gap-free segment
(``Settings.line_refine``, on by default since stop 63; docs/mismatch.md 9.38): the
line's columns span the whole record, so off its frequency by half the segment's bin they
lose their phase and most of the line's power (kernel 370108: `visible` 44.5, GLR 13 at
the grid's frequency, nothing reported).  Read off the whole record, the frequency is the
line's and the evidence its.  Development seed (< 20000)."""

from __future__ import annotations

from dataclasses import replace

import pytest
from scipy import stats

from tmopt.mismatch import generic
from tmopt.mismatch.diagnose import Settings, fit_state, prepare, residual_groups
from tmopt.mismatch.effects import Context
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.realistic import OOC, draw_scenario, realistic_recording

SEED = 9001
DURATION, GAP = 1200.0, (300.0, 340.0)


@pytest.fixture(scope="module")
def gapped_line():
    """A 1200 s kernel recording cut at 300-340 s (longest piece 860 s, bins 1.16 mHz
    apart) with a 1e-12 m s^-2 force line on x1 half-way between two of its bins."""
    sc = replace(draw_scenario(SEED, "kernel"), duration=DURATION, sample_rate=2.0,
                 gaps=((*GAP, "drop"),), glitches=())  # fmt: skip
    f_line = 5.5 / (DURATION - GAP[1])
    line = OOC("unmodelled_line", 1e-12, "x1", {"f_hz": f_line, "phase": 0.3})
    rec, _ = realistic_recording(sc, (), [line], SEED, "kernel")
    data, basis = prepare(data_from_recording(rec))
    state = fit_state(data, basis, [], [], False, Settings())
    ctx = Context(data, basis, state.eq_fit.residual, state.eq_noise)
    return ctx, residual_groups(data, state)["equation"], f_line, (data, basis, state)


def _read(ctx, group, refine: bool) -> tuple[float, float, float]:
    [cand] = generic._lines(ctx, refine)
    assert cand.channel == "x1"
    lam = group.glr(cand.columns)
    return cand.fixed["frequency_hz"], lam, cand.trials * float(stats.chi2.sf(lam, 2))


def test_the_refined_line_sits_at_its_frequency_and_is_significant(gapped_line):
    ctx, group, f_line, _ = gapped_line
    f, lam, p = _read(ctx, group, True)
    assert abs(f - f_line) <= 1.0 / (4 * DURATION), (f, f_line)
    assert p < 1e-6, (lam, p)


def test_on_the_segments_grid_the_same_line_is_off_and_lost(gapped_line):
    """What the refinement is for: the grid's nearest frequency is half a bin off and its
    sinusoid keeps a small part of the line (GLR ~9 against ~70)."""
    ctx, group, f_line, _ = gapped_line
    f, lam, p = _read(ctx, group, False)
    f_ref, lam_ref, _ = _read(ctx, group, True)
    assert abs(f - f_line) > 0.25 / (DURATION - GAP[1])
    assert lam_ref > 4 * lam and p > 0.01, (lam, lam_ref, p)


def test_the_refined_search_counts_its_finer_grid_in_its_trials(gapped_line):
    ctx, _, _, _ = gapped_line
    [coarse] = generic._lines(ctx, False)
    [fine] = generic._lines(ctx, True)
    longest = ctx.data.longest.stop - ctx.data.longest.start
    assert fine.trials == pytest.approx(coarse.trials * DURATION / (longest * ctx.data.dt))


def test_the_tools_defaults_read_the_line_off_the_whole_record(gapped_line):
    """On by default since 9.38's paired test: the first step's line candidate is the
    refined one, and it is the step's most significant."""
    from tmopt.mismatch.diagnose import evaluate

    _, _, f_line, (data, basis, state) = gapped_line
    evals = evaluate(data, basis, state, Settings(), set())
    [line] = [e for e in evals if (e.candidate.fixed or {}).get("feature") == "line"]
    assert abs(line.candidate.fixed["frequency_hz"] - f_line) <= 1.0 / (4 * DURATION)
    assert line.p_holm < 1e-6 and line is min(evals, key=lambda e: e.p_holm)


def test_line_profile_reads_the_lines_significance_by_its_profile_ratio(gapped_line):
    """``Settings.line_profile`` (off; docs 9.40): the line's p-value reads its profile
    ratio -- the equation noise model estimated again with the line fitted, which the
    null's spline had taken in (ratio > GLR) -- and keeps its GLR's p-value beside it; an
    onset's significance is not read so (that is ``onset_profile``'s)."""
    from tmopt.mismatch.diagnose import _equation_alternatives, _generic_feature, evaluate

    _, _, _, (data, basis, state) = gapped_line
    on = Settings(line_profile=True)
    by = {s: {_generic_feature(e.candidate): e for e in evaluate(data, basis, state, s, set())}
          for s in (on, Settings())}  # fmt: skip
    line_on, line_off = by[on]["line"], by[Settings()]["line"]
    ratio = _equation_alternatives(data, basis, state, on)["equation_profile"](
        line_on.candidate.columns, float("inf"))
    assert ratio > line_on.glr == pytest.approx(line_off.glr)
    assert line_on.p_value == pytest.approx(min(1.0, line_on.candidate.trials *
                                                stats.chi2.sf(ratio, 2)), rel=1e-9)
    assert line_on.p_glr == pytest.approx(line_off.p_value) and line_off.p_glr is None
    assert by[on]["step"].p_glr is None  # an onset: not read by line_profile
