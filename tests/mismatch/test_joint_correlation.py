"""A twin pair's two estimates combined with their correlation
(``Settings.joint_correlation``; docs/mismatch.md 9.37, 9.39): an accelerometer
cross-talk is estimated by the equation group and by the kinematic twin, and a's own
accelerometer noise is in both residuals.  Combined as if independent, two estimates
correlated rho give a statistic inflated ~1 + rho; their generalised least-squares mean,
rho read from the recording's scores, is chi^2(1) again.  Development seeds (< 20000)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tmopt.mismatch.diagnose import (
    Settings,
    _joint,
    _score_correlation,
    admissible_correlation,
    evaluate,
    fit_state,
    gls_mean_lr,
    prepare,
    residual_groups,
)
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.realistic import draw_scenario, realistic_recording


def test_the_gls_mean_is_that_of_the_covariance_solved_directly():
    """Against the textbook form solved by linear algebra: (1' S^-1 b)^2 / (1' S^-1 1)."""
    rng = np.random.default_rng(1)
    for _ in range(50):
        b, s, rho = rng.normal(size=2), rng.uniform(0.1, 3.0, 2), rng.uniform(-0.9, 0.9)
        cov = np.array([[s[0] ** 2, rho * s[0] * s[1]], [rho * s[0] * s[1], s[1] ** 2]])
        one = np.ones(2)
        direct = (one @ np.linalg.solve(cov, b)) ** 2 / (one @ np.linalg.solve(cov, one))
        assert gls_mean_lr(b[0], s[0], b[1], s[1], rho) == pytest.approx(direct, rel=1e-10)
    # rho = 0: the inverse-variance mean's squared z-score
    w1, w2 = 1 / 0.5**2, 1 / 2.0**2
    mean = (w1 * 1.2 + w2 * -0.4) / (w1 + w2)
    assert gls_mean_lr(1.2, 0.5, -0.4, 2.0, 0.0) == pytest.approx(mean**2 * (w1 + w2))


def test_correlated_estimates_are_chi2_only_when_their_correlation_is_counted():
    """20,000 null pairs of equal weight correlated 0.4: the independent combination's
    mean is 1 + rho, the GLS mean's 1."""
    rng = np.random.default_rng(2)
    rho = 0.4
    z = rng.multivariate_normal([0, 0], [[1, rho], [rho, 1]], size=20000)
    naive = np.array([gls_mean_lr(a, 1.0, b, 1.0, 0.0) for a, b in z])
    gls = np.array([gls_mean_lr(a, 1.0, b, 1.0, rho) for a, b in z])
    assert naive.mean() == pytest.approx(1 + rho, abs=0.05)
    assert gls.mean() == pytest.approx(1.0, abs=0.05)
    assert np.mean(gls > 6.635) == pytest.approx(0.01, abs=0.003)


def test_a_read_correlation_never_gives_an_estimate_a_negative_weight():
    """9.39's loss: the equation estimate 58x less precise than the twin's, a large gain
    seen by the equation alone, the twin at zero (its veto).  With rho 0.2 read, the raw
    GLS mean weights the equation's estimate negatively and the veto fails (LR ~31);
    clipped to s_min/s_max, the twin alone decides (LR 0)."""
    b1, s1, b2, s2, rho = 30 * 58.0, 58.0, 0.0, 1.0, 0.2
    assert gls_mean_lr(b1, s1, b2, s2, rho) > 20
    assert admissible_correlation(rho, s1, s2) == pytest.approx(1 / 58)
    assert gls_mean_lr(b1, s1, b2, s2, admissible_correlation(rho, s1, s2)) < 1e-9
    assert admissible_correlation(-0.3, 1.0, 1.2) == 0.0
    assert admissible_correlation(0.4, 1.0, 1.2) == 0.4  # admissible: kept as read


class _Fixed:
    """A group with a fixed estimate and score, for :func:`_joint` alone."""

    def __init__(self, b: float, s: float, scores: np.ndarray, index=None):
        self.b, self.s, self._scores, self.index = b, s, scores, index

    def estimate(self, _col):
        return self.b, self.s

    def scores(self, _col):
        return self._scores


def test_the_twin_pairs_statistic_reads_the_clipped_correlation():
    """Through :func:`_joint`: scores correlated ~0.9 (far beyond 1/58) read as 1/58."""
    from types import SimpleNamespace

    rng = np.random.default_rng(5)
    e = rng.normal(size=4000)
    k = 0.9 * e + math.sqrt(1 - 0.81) * rng.normal(size=4000)
    groups = {"equation": _Fixed(30 * 58.0, 58.0, e), "joint_correlation": True,
              "kinematic": _Fixed(0.0, 1.0, k, np.arange(4000))}  # fmt: skip
    cand = SimpleNamespace(columns=[None], twin=None)
    assert _joint(cand, groups) < 1e-9
    groups["joint_correlation"] = False
    assert _joint(cand, groups) == pytest.approx(gls_mean_lr(30 * 58.0, 58.0, 0.0, 1.0, 0.0))


def _scores(rng, n: int, spread: np.ndarray):
    """Two narrowband scores whose residuals share a noise, in the second one through a
    filter that spreads it over a few samples (as two groups' whitening filters do); the
    second group's rows start one sample later (its ``index``)."""
    t = np.arange(n)
    u1 = np.cos(2 * np.pi * 0.013 * t)
    u2 = 0.7 * np.cos(2 * np.pi * 0.013 * t[1:])
    e = rng.normal(size=n + spread.size)
    shared = e[spread.size:]
    spread_shared = np.convolve(e, spread, mode="full")[spread.size: spread.size + n]
    r1 = shared + rng.normal(size=n)
    r2 = spread_shared[1:] + rng.normal(size=n - 1)
    return u1 * r1, u2 * r2, t[1:]


def test_the_score_correlation_is_the_correlation_of_the_two_estimates():
    """Over 600 draws, the estimates' (the scores' sums) correlation against the mean of
    the per-draw estimate: the long-run window reads the shared noise spread over lags,
    the lag-0 product alone (lags=0) misses most of it."""
    rng = np.random.default_rng(3)
    spread = np.array([0.1, 0.3, 0.5, 0.3, 0.1, -0.2, 0.2])[::-1]
    sums, est, est0 = [], [], []
    for _ in range(600):
        s1, s2, idx = _scores(rng, 3000, spread)
        sums.append((s1.sum(), s2.sum()))
        est.append(_score_correlation(s1, s2, idx))
        est0.append(_score_correlation(s1, s2, idx, lags=0))
    truth = np.corrcoef(np.array(sums).T)[0, 1]
    assert truth > 0.25  # the case is not trivial
    assert np.mean(est) == pytest.approx(truth, abs=0.06)
    assert np.mean(est0) < truth - 0.1
    assert _score_correlation(None, s2, idx) == 0.0  # one group cannot see it


@pytest.fixture(scope="module")
def clean_state():
    """A clean 1200 s kernel recording, every axis excited."""
    seed = 9011
    sc = replace(draw_scenario(seed, "kernel"), duration=1200.0, sample_rate=2.0,
                 gaps=(), glitches=())  # fmt: skip
    rec, _ = realistic_recording(sc, (), (), seed, "kernel")
    data, basis = prepare(data_from_recording(rec))
    return data, basis, fit_state(data, basis, [], [], False, Settings())


def test_the_switch_reaches_the_accelerometer_cross_talks_statistic(clean_state):
    """With ``joint_correlation`` each acc cross-talk's statistic is the GLS mean's, its
    rho the recording's own kept admissible; without it, the inverse-variance mean's."""
    data, basis, state = clean_state
    on, off = Settings(joint_correlation=True), Settings()
    by_key = {s: {e.candidate.key: e for e in evaluate(data, basis, state, s, set())}
              for s in (on, off)}  # fmt: skip
    groups = residual_groups(data, state)
    acc = [k for k in by_key[on] if k.startswith("sensing_cross_talk[acc:")]
    assert len(acc) == 12
    moved = 0
    for key in acc:
        cand = by_key[on][key].candidate
        b1, s1 = groups["equation"].estimate(cand.columns[0])
        b2, s2 = groups["kinematic"].estimate(cand.twin)
        rho = admissible_correlation(
            _score_correlation(groups["equation"].scores(cand.columns[0]),
                               groups["kinematic"].scores(cand.twin),
                               groups["kinematic"].index), s1, s2)  # fmt: skip
        assert by_key[on][key].glr == pytest.approx(gls_mean_lr(b1, s1, b2, s2, rho))
        assert by_key[off][key].glr == pytest.approx(gls_mean_lr(b1, s1, b2, s2, 0.0))
        moved += not math.isclose(by_key[on][key].glr, by_key[off][key].glr, rel_tol=1e-6)
    assert moved >= 6  # the correlation is read, not zero

