"""Low-frequency shapes judged against their null under the 1/f^2 background (issue 26,
docs/mismatch.md 9.11): a bias ramp, the curvature feature and the drift's shape check
live in the record's lowest bins, where clean flight-like recordings give GLRs ~1.6x
chi^2 (``calibration.LOWFREQ_NULL``, calibrated by
``experiments/mismatch_lowfreq_probe.py``)."""

from __future__ import annotations

import math

import pytest
from scipy import stats

from tmopt.mismatch import calibration as cal
from tmopt.mismatch.diagnose import Settings, _tests, fit_state, lowfreq_glr, prepare
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.realistic import draw_scenario, realistic_recording


@pytest.mark.parametrize("which", sorted(cal.LOWFREQ_NULL))
@pytest.mark.parametrize("dof", [1, 2])
def test_the_calibrated_statistic_has_the_null_models_p_value(which, dof):
    """The returned chi^2 statistic carries the p-value of ``dof * scale * F(dof, nu)``,
    so trials, Holm and BIC use it as any GLR; it never exceeds the raw GLR (every
    calibrated scale is >= 1) and keeps the order of the raw values."""
    scale, nu = cal.LOWFREQ_NULL[which]
    assert scale >= 1.0 and nu >= 1.0
    previous = -math.inf
    for lam in (0.5, 5.0, 20.0, 80.0, 400.0):
        eq = lowfreq_glr(lam, dof, which)
        p_model = stats.f.sf(lam / (scale * dof), dof, nu)
        assert stats.chi2.sf(eq, dof) == pytest.approx(p_model, rel=1e-6)
        assert eq <= lam + 1e-9
        assert eq > previous
        previous = eq


@pytest.mark.slow  # ~7 s alone, 21 s on a loaded machine
def test_a_clean_recordings_low_frequency_candidates_are_deflated_and_nothing_else():
    """On a clean flight-like recording (calibration seed 21000, kernel), with both nulls
    in ``Settings.lowfreq`` the drift's, the curvature's and the readout timing's p-values
    come from their calibrated nulls, every other candidate's is unchanged, and no GLR
    changes (BIC gains and the ambiguity band compare raw GLRs)."""
    sc = draw_scenario(21000, "kernel")
    rec, _ = realistic_recording(sc, (), (), 21000, "kernel")
    data, basis = prepare(data_from_recording(rec))
    on, off = Settings(lowfreq=("ramp", "curvature", "timing")), Settings(lowfreq=())
    state = fit_state(data, basis, [], [], False, on)
    ev_on = _tests(data, basis, state, on, set())[0]
    ev_off = _tests(data, basis, state, off, set())[0]
    assert [e.candidate.key for e in ev_on] == [e.candidate.key for e in ev_off]
    kinds = {(e.candidate.effect, e.candidate.fixed.get("feature")): e.candidate.null
             for e in ev_on}  # fmt: skip
    assert kinds[("bias_drift", None)] == "ramp"
    assert kinds[("unexplained", "curvature")] == "curvature"
    assert kinds[("unexplained", "readout timing")] == "timing"
    timings = sum(bool(data.tones(a)) for a in range(4))  # one per excited axis
    assert sum(bool(e.candidate.null) for e in ev_on) == 8 + timings  # 4 ramps, 4 curvatures
    for e, raw in zip(ev_on, ev_off):
        assert e.glr == pytest.approx(raw.glr)  # BIC gains compare raw GLRs
        if e.candidate.null:
            eq = lowfreq_glr(raw.glr, e.dof, e.candidate.null)
            assert e.p_value == pytest.approx(min(1.0, e.candidate.trials
                                                  * stats.chi2.sf(eq, e.dof)))  # fmt: skip
            assert e.p_value >= raw.p_value
        else:
            assert e.p_value == pytest.approx(raw.p_value)


def test_the_curvature_and_timing_nulls_are_on_by_default_and_unknown_nulls_are_refused():
    """The ramp's null cost two true drifts on never-seen recordings (docs 9.11): off by
    default; the shape check's null is measured, not a setting."""
    assert Settings().lowfreq == ("curvature", "timing")
    for bad in (("shape",), ("drift",)):
        with pytest.raises(ValueError):
            Settings(lowfreq=bad)
