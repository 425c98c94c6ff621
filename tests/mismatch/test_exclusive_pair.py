"""An accelerometer scale and an actuation gain of one axis never share the model
(docs/mismatch.md 9.12 (c), :attr:`tmopt.mismatch.effects.base.Candidate.excludes`).

``e acc_a + g F_a`` with ``g = -e`` is ``e (acc_a - F_a)``: Eq. 10's left-hand side less
the force -- the axis' residual, its noise included.  With both in the model the fit
explains the noise: on foreign 80052 (a bias drift alone) a gain[y1] reached GLR 19615
once the scale was in (GLR 19 without it), the backward pass then dropped the scale and
the gain was named with the stale ΔBIC 19604.  Development seeds for the mechanism; the
read recording itself as the slow regression test.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tmopt.mismatch.diagnose import Evaluation, Settings, _clashes, _Group, fit_state, prepare
from tmopt.mismatch.effects.actuation_gain import ActuationGain
from tmopt.mismatch.effects.base import Context
from tmopt.mismatch.effects.readout_scale import ReadoutScale
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.realistic import draw_scenario, realistic_recording


@pytest.mark.parametrize("seed,backend", [(17051, "kernel"), (17052, "foreign")])
def test_the_two_columns_together_fit_the_noise_of_a_clean_recording(seed, backend):
    sc = draw_scenario(seed, backend, duration=1200.0, sample_rate=2.5, gaps=())
    data, basis = prepare(data_from_recording(realistic_recording(sc, [], [], seed,
                                                                  backend)[0]))  # fmt: skip
    st = fit_state(data, basis, [], [], False, Settings())
    ctx = Context(data, basis, st.eq_fit.residual, st.eq_noise)
    group = _Group(None, st.eq_cols, st.eq_fit, st.eq_noise.whiten)
    scale = {c.key: c for c in ReadoutScale().candidates(ctx)}["readout_scale[acc:y1]"]
    gain = {c.key: c for c in ActuationGain().candidates(ctx)}["actuation_gain[y1]"]
    alone = max(group.glr(scale.columns), group.glr(gain.columns))
    assert alone < 15  # each alone: clean (chi^2_1)
    assert group.glr(scale.columns + gain.columns) > 100 * alone + 500  # together: noise
    assert gain.key in scale.excludes


def test_the_exclusion_holds_either_way_round():
    scale = Evaluation(_candidate("readout_scale", "acc:x2", ("actuation_gain[x2]",)),
                       0.0, 1, 1, 1.0)  # fmt: skip
    gain = Evaluation(_candidate("actuation_gain", "x2"), 0.0, 1, 1, 1.0)
    other = Evaluation(_candidate("actuation_gain", "x1"), 0.0, 1, 1, 1.0)
    assert _clashes(gain, [scale]) and _clashes(scale, [gain])
    assert not _clashes(other, [scale]) and not _clashes(scale, [other])


def _candidate(effect: str, channel: str, excludes: tuple[str, ...] = ()):
    from tmopt.mismatch.effects.base import Candidate

    return Candidate(effect, channel, "equation", ["p"], ["1"], excludes=excludes)


@pytest.mark.slow
def test_foreign_80052_names_the_drift_alone():
    """The read recording (stop 35's tenth run): the drift named, the scale-or-gain of y1
    reported ambiguous, no gain named."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "experiments"))
    from mismatch_realistic import build, cases

    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.report import build_report

    case = next(c for c in cases("foreign", 80000, False) if c["seed"] == 80052)
    sc, effects, ooc, _ = build(case)
    rec, _ = realistic_recording(sc, effects, ooc, 80052, "foreign")
    rep = build_report(diagnose(data_from_recording(rec)))
    assert [(e["name"], e["channel"]) for e in rep["effects"]] == [("bias_drift", "x1")]
    names = {(a["name"], a["channel"]) for a in rep["ambiguous"]}
    assert ("readout_scale", "acc:y1") in names
