"""``Settings.convention_profile`` (docs/mismatch.md 9.32): where Eq. 10 leaves the
accelerometer's sampling convention undecided, the kinematic group's profile likelihood
decides when its lead reaches ``calibration.CONVENTION_LEAD``.  The records are clean
foreign recordings of the rule's null (calibration seeds 37400-37459), each with its
scenario's convention replaced by the one recorded."""

from __future__ import annotations

from dataclasses import replace

import pytest

import tmopt.mismatch.realistic as R
from tmopt.mismatch import calibration as cal
from tmopt.mismatch.diagnose import Settings, prepare
from tmopt.mismatch.fit import data_from_recording


def _read(seed: int, recorded: str, on: bool):
    sc = replace(R.draw_scenario(seed, "foreign"), acc_convention=recorded)
    rec = R.realistic_recording(sc, seed=seed, backend="foreign")[0]
    data, _ = prepare(data_from_recording(rec), settings=Settings(convention_profile=on))
    return data.acc_convention, data.usage["acc_convention_evidence"]


@pytest.mark.parametrize(("seed", "recorded", "today"), [
    (37408, "mean", "end"),  # the equation group leaves mean and end; gamma says end
    (37451, "end", "held"),  # all three left; held kept
])  # fmt: skip
def test_a_clear_profile_lead_reads_the_recorded_convention(seed, recorded, today):
    off, ev_off = _read(seed, recorded, False)
    on, ev_on = _read(seed, recorded, True)
    assert off == today  # the shipped default's misread, the rule's reason
    assert "profile_behind" not in ev_off
    assert on == recorded
    assert ev_on["by"].startswith("kinematic group's profile likelihood")
    behind = ev_on["profile_behind"]
    assert set(behind) == set(ev_on["left"]) and behind[recorded] == 0.0
    assert min(v for c, v in behind.items() if c != recorded) >= cal.CONVENTION_LEAD


def test_the_equation_groups_decision_is_left_alone():
    """Where Eq. 10 decides (foreign 37400 recorded held), the profile is not consulted."""
    conv, ev = _read(37400, "held", True)
    assert conv == "held" and ev["by"].startswith("equation group")
    assert "left" not in ev and "profile_behind" not in ev


def test_convention_profile_must_be_a_flag():
    with pytest.raises(ValueError, match="convention_profile must be True or False"):
        Settings(convention_profile="yes")


def test_profile_pick_needs_a_lead_over_every_other():
    from tmopt.mismatch.diagnose import profile_pick

    assert profile_pick({"held": 0.0, "mean": 5.0, "end": 12.0}, 3.84) == "held"
    assert profile_pick({"held": 0.0, "mean": 5.0, "end": 3.0}, 3.84) is None  # end is near
    assert profile_pick({"mean": 0.0}, 3.84) is None  # nothing to compare
