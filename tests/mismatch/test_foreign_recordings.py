"""Recordings without the optional channels (another simulator may not write them)."""

from __future__ import annotations

import json

from tmopt.mismatch.__main__ import main
from tmopt.mismatch.generate import generate_recording
from tmopt.mismatch.recording import Recording, write_recording


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
