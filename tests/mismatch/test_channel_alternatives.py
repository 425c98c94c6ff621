"""A force whose channel the data barely chose (docs/mismatch.md 9.35): the same effect on
another channel among its near alternatives is said beside the name, which is kept."""

from __future__ import annotations

from types import SimpleNamespace

from tmopt.mismatch.report import channel_alternatives, conclusion


def _ev(effect: str, channel: str, group: str = "equation", dbic: float = 10.0):
    return SimpleNamespace(candidate=SimpleNamespace(effect=effect, channel=channel,
                                                     group=group), dbic=dbic)  # fmt: skip


def test_a_force_lists_the_same_effect_on_other_channels_only():
    ev = _ev("bias_drift", "x1")
    alts = [_ev("bias_drift", "y2", dbic=9.2), _ev("stiffness_drift", "x1", dbic=8.0),
            _ev("bias_drift", "x2", dbic=5.0), _ev("bias_drift", "y2", dbic=4.5)]
    assert channel_alternatives(ev, alts) == ["x2", "y2"]
    assert channel_alternatives(ev, [_ev("stiffness_drift", "y2")]) == []


def test_a_kinematic_effect_has_none():
    """Per-axis readout rows: a readout scale's channel is not a tie of the f_B-free rows
    (disp/acc scales were named on the right channel even at small margins, 9.7)."""
    ev = _ev("readout_scale", "x2", group="kinematic")
    assert channel_alternatives(ev, [_ev("readout_scale", "acc:x2", "kinematic")]) == []


def test_the_conclusion_says_the_channel_was_barely_chosen():
    rep = {"status": "diagnosed", "mismatch_detected": True, "features": [], "ambiguous": [],
           "checks": [], "locations_unexplained": {"frequency_hz": [], "time_s": []},
           "effects": [{"name": "bias_drift", "channel": "x1", "channel_alternatives": ["y2"]},
                       {"name": "actuation_gain", "channel": "x2", "channel_alternatives": []}]}
    assert conclusion(rep) == ("mismatch explained by bias_drift [x1] (or [y2]: the channel "
                               "barely chosen), actuation_gain [x2]")
