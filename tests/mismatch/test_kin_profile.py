"""A kinematic candidate read by its profile likelihood ratio (issue 26; docs/mismatch.md
9.29; :func:`tmopt.mismatch.diagnose._kin_profile`).

The GLR reads a kinematic candidate under the noise model estimated from the residual that
still holds it, and a readout scale that dominates the lowest bins of the residual's
pieces is taken into that spectrum (docs 9.24).  The profile ratio fits the candidate's
column *and* estimates the noise model again under it, and scores each fit by Whittle's
likelihood under its own model, divided by the taper's over-count of the pooled
periodogram (Hann: 35/18).  Development seeds (< 20000).  On by default
(``Settings.kin_profile``) since stop 55, after two never-seen draws scored it (9.31).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from tmopt.mismatch.diagnose import (
    Settings,
    _fit_kin,
    _given,
    _kin_candidates,
    _kin_groups,
    _tests,
    diagnose,
    effect_parameters,
    fit_state,
    prepare,
    residual_groups,
)
from tmopt.mismatch.effects import Injection
from tmopt.mismatch.fit import Column, data_from_recording
from tmopt.mismatch.noise_model import ROUGHNESS, Layout, taper

from .test_kinematic_alternative import SEED, _recording  # the same record as kin_refit's

ON = Settings(kin_profile=True)
OFF = Settings(kin_profile=False)


@pytest.fixture(scope="module")
def dominated():
    """A displacement readout scale of 1e-3 on x2: the kinematic residual is the effect
    (GLR 2.5 under the null's noise model)."""
    inj = Injection("readout_scale", 1e-3, "x2", options={"sensor": "disp"})
    rec = _recording(SEED, "kernel", [inj])
    return rec, inj, diagnose(data_from_recording(rec), ON)


def test_a_readout_scale_that_dominates_its_residual_is_named(dominated):
    """Named alone, its estimate within 5 sigma of the truth; with the option off nothing
    is named on the same record."""
    rec, inj, dg = dominated
    assert [ev.candidate.key for ev, _ in dg.selected] == ["readout_scale[disp:x2]"]
    e, sigma = effect_parameters(dg.after, dg.selected[0][0].candidate)["e"]
    assert abs(abs(e) - inj.magnitude) < 5 * sigma, (e, sigma)
    assert not diagnose(data_from_recording(rec), OFF).selected


def test_backward_elimination_reads_it_by_its_profile_too(dominated):
    """``_given`` rebuilds the model without the effect, where the null's noise model
    takes it in again: read by its profile ratio it stays needed; off, it would go."""
    dg = dominated[2]
    chosen = [ev for ev, _ in dg.selected]
    n_tests = len(dg.steps[0])
    p, dbic = _given(dg.data, dg.basis, chosen, 0, dg.settings, n_tests)
    assert p < 1e-10 and dbic > 100, (p, dbic)
    p_off, _ = _given(dg.data, dg.basis, chosen, 0, OFF, n_tests)
    assert p_off > dg.settings.alpha, p_off


def _whittle_by_hand(residual: np.ndarray, noise) -> float:
    """Whittle's log-likelihood from numpy's FFT per piece and scipy's B-spline (the
    Hann-tapered periodogram of each piece, scaled to the variance per bin), less the
    roughness penalty on each spline's second differences."""
    spline = [BSpline(noise.knots, c, 3, extrapolate=False) for c in noise.coefs]
    d2 = noise.coefs[:, 2:] - 2 * noise.coefs[:, 1:-1] + noise.coefs[:, :-2]
    total = -ROUGHNESS * float(np.sum(d2**2))
    for a, b in noise.layout.bounds:
        m = b - a
        if m < 16:
            continue
        w = taper(m, noise.taper_fraction)
        f = np.fft.rfftfreq(m, 1 / noise.fs)[1:]
        per = np.abs(np.fft.rfft(residual[:, a:b] * w, axis=1)[:, 1:]) ** 2 / (m * np.mean(w**2))
        u = np.clip(np.log(f), noise.knots[0], noise.knots[-1])
        for j, s in enumerate(spline):
            log_s = s(u)
            total -= float(np.sum(log_s + per[j] / np.exp(log_s)))
    return total


def test_the_statistic_is_the_profile_ratio_computed_a_second_way(dominated):
    """The statistic the selection reads equals ``2 (ll1 - ll0) / inflation`` with both
    likelihoods computed by hand (numpy FFT, scipy B-splines) and the Hann factor from
    its closed form, 35/18 (long pieces)."""
    dg = dominated[2]
    d, basis = dg.data, dg.basis
    st = fit_state(d, basis, [], [], False, ON)
    [cand] = [c for c in _kin_candidates(d, basis, st, ON) if c.key == "readout_scale[disp:x2]"]
    read = _kin_groups(d, st, [cand], ON)["kinematic_profile"]
    got = read(cand.columns, 1e9)  # above the screen: the ratio is computed
    fit1, noise1 = _fit_kin(st.kinematic_target(d), st.kin_cols + cand.columns,
                            d.kin_layout, d.fs)  # fmt: skip
    ll0 = _whittle_by_hand(st.kin_fit.residual, st.kin_noise)
    ll1 = _whittle_by_hand(fit1.residual, noise1)
    assert st.kin_noise.taper_inflation() == pytest.approx(35 / 18, rel=0.02)
    want = 2 * (ll1 - ll0) / st.kin_noise.taper_inflation()
    assert got == pytest.approx(want, rel=1e-6), (got, want)
    lam = residual_groups(d, st)["kinematic"].glr(cand.columns)
    assert lam < 5 < 100 < got, (lam, got)


def test_pure_noise_in_the_lowest_bins_reads_close_to_chi2_1():
    """Blue noise (the kinematic group's), a column of 2.5 cycles per record -- the worst
    place, where the spectrum rests on a handful of bins -- and no effect: the profile
    ratio over the taper's factor has a mean near one (docs 9.29 measured 1.19 on 150
    draws of 4000 samples, and 0.99 on 1,052 candidates of 60 clean flight-like
    recordings)."""
    fs, m = 2.0, 2000
    lay = Layout.whole(m)
    t = np.arange(m) / fs
    out = []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        y = np.diff(rng.standard_normal(m + 2), 2)[None, :] + 0.3 * rng.standard_normal((1, m))
        col = Column("c", 0.1 * np.sin(2 * np.pi * 2.5 * t / (m / fs) + seed)[None, :])
        f0, n0 = _fit_kin(y, [], lay, fs)
        f1, n1 = _fit_kin(y, [col], lay, fs)
        ratio = 2 * (n1.whittle_loglik(f1.residual) - n0.whittle_loglik(f0.residual))
        out.append(ratio / n0.taper_inflation())
    out = np.array(out)
    assert 0.6 < out.mean() < 1.6 and np.mean(out > 3.84) < 0.15, (out.mean(), out.max())


@pytest.mark.parametrize("backend", ["kernel", "foreign"])
def test_on_a_clean_recording_nothing_reaches_the_level(backend):
    """Under "no effect" every kinematic statistic of the first step stays below the
    selection's level (chi^2_1 at FAMILY_ALPHA / 150: 15.9), and the other groups'
    statistics are untouched."""
    d, basis = prepare(data_from_recording(_recording(SEED, backend)))
    st = fit_state(d, basis, [], [], False, OFF)
    on = {e.candidate.key: e for e in _tests(d, basis, st, ON, set())[0]}
    off = {e.candidate.key: e for e in _tests(d, basis, st, OFF, set())[0]}
    assert on.keys() == off.keys()
    assert all(on[k].glr == off[k].glr for k in on if on[k].candidate.group != "kinematic")
    kin = {k: round(on[k].glr, 2) for k in on if on[k].candidate.group == "kinematic"}
    assert kin and max(kin.values()) < 15.9, kin


def test_a_bad_switch_is_refused_naming_it():
    with pytest.raises(ValueError, match="kin_profile must be True or False"):
        Settings(kin_profile="yes")
