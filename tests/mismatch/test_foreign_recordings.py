"""Recordings written by other simulators: optional channels missing, other timestamping."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tmopt.mismatch.__main__ import main
from tmopt.mismatch.diagnose import diagnose
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generate import calibrated_injection, generate_recording
from tmopt.physics.recording import Recording, write_recording


def test_without_witnesses_rotation_coupling_is_reported_untestable(tmp_path):
    rec, _ = generate_recording((), seed=3, duration=600.0)
    bare = {k: v for k, v in rec.channels.items()
            if not k.startswith(("sc_omega", "ref_"))}
    path = write_recording(Recording(bare, dict(rec.attrs)), tmp_path / "bare.h5")
    assert main([str(path), "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["mismatch_detected"] is False
    untested = [n for n in report["not_identifiable"] if n["name"] == "rotation_coupling"]
    assert len(untested) == 1 and untested[0]["reason"].startswith("untestable: ")
    assert "sc_omega" in untested[0]["reason"]


def _force_stamped(rec, lag: int) -> Recording:
    """The same run as a simulator stamping its forces ``lag`` samples late (< 0: early)."""
    ch = dict(rec.channels)
    for a in ("x1", "x2", "y1", "y2"):
        f = ch[f"force_{a}"]
        ch[f"force_{a}"] = (np.concatenate([np.zeros(lag), f[:-lag]]) if lag > 0
                            else np.concatenate([f[-lag:], np.zeros(-lag)]))
    return Recording(ch, dict(rec.attrs))


@pytest.mark.parametrize("lag", [1, -1])
def test_force_timestamp_convention_is_aligned_not_mistaken_for_physics(lag):
    rec, truth = generate_recording((), seed=5, duration=600.0)
    dg = diagnose(data_from_recording(_force_stamped(rec, lag)))
    assert not dg.selected  # a convention is not a mismatch
    assert any(f"stamped 1 sample(s) {'late' if lag > 0 else 'early'}" in n
               for n in dg.data.notes)
    fit = dg.before.eq_fit
    k1 = truth["nominal"]["k1xx"]
    assert abs(fit.value("k1xx") - k1) < 5 * fit.sigma("k1xx")


def test_an_effect_is_still_found_through_a_shifted_convention():
    rec, _ = generate_recording([calibrated_injection("actuation_gain", "large")], seed=6,
                                duration=600.0)
    dg = diagnose(data_from_recording(_force_stamped(rec, 1)))
    assert [(ev.candidate.effect, ev.candidate.channel) for ev, _ in dg.selected][:1] == [
        ("actuation_gain", "x1")]


def test_recordings_stamped_like_ours_are_left_alone():
    rec, _ = generate_recording((), seed=7, duration=600.0)
    data = data_from_recording(rec)
    dg = diagnose(data)
    assert dg.data.n == data.n and not any("stamped" in n for n in dg.data.notes)
