"""python -m tmopt.mismatch RECORDING --out DIR: files, exit codes, one-line errors."""

from __future__ import annotations

import json
import math

import pytest

from tmopt.mismatch.__main__ import main
from tmopt.physics import MultiSine, SimulationConfig, simulate
from tmopt.physics.recording import recording_from_simulation, write_recording


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    res = simulate(MultiSine(5e-5, 2 * math.pi / 300), MultiSine(3e-5, 2 * math.pi / 500),
                   SimulationConfig(duration=300.0), seed=41)  # fmt: skip
    folder = tmp_path_factory.mktemp("rec")
    rec = recording_from_simulation(res, 0, description="clean cli test")
    write_recording(rec, folder / "clean.h5")
    write_recording(rec, folder / "clean.csv")
    return folder


@pytest.mark.parametrize("name", ["clean.h5", "clean.csv"])
def test_cli_writes_the_report(recording, tmp_path, capsys, name):
    out = tmp_path / "out"
    assert main([str(recording / name), "--out", str(out)]) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["mismatch_detected"] is False
    assert (out / "report.md").exists() and (out / "residual_psd.png").exists()
    assert "no significant mismatch" in capsys.readouterr().out
    assert rep["settings"]["rejudge"] is True and rep["settings"]["shape_search"] is True
    assert rep["settings"]["shape_placements"] is True and rep["settings"]["pairs"] is True
    assert rep["settings"]["true_position"] is True and rep["settings"]["rails"] == "fallback"
    assert rep["settings"]["kin_refit"] is False and rep["settings"]["witness_refit"] is True
    assert rep["settings"]["kin_profile"] is True and rep["settings"]["onset_profile"] is False
    assert rep["settings"]["convention_profile"] is True
    assert rep["settings"]["timing_regressor"] == "tones"
    assert rep["settings"]["line_refine"] is True and rep["settings"]["line_profile"] is False
    assert rep["settings"]["joint_correlation"] is False


def test_cli_can_turn_the_stop_40_to_56_rules_off(recording, tmp_path):
    out = tmp_path / "out"
    assert main([str(recording / "clean.h5"), "--out", str(out), "--no-rejudge",
                 "--no-in-place", "--no-shape-search", "--no-shape-placements", "--no-pairs",
                 "--no-true-position", "--rails", "read", "--kin-refit",
                 "--no-kin-profile", "--onset-profile", "--no-witness-refit",
                 "--no-convention-profile", "--timing-regressor", "band",
                 "--no-line-refine", "--joint-correlation", "--line-profile",
                 "--no-plots"]) == 0  # fmt: skip
    settings = json.loads((out / "report.json").read_text())["settings"]
    assert settings["rejudge"] is False and settings["in_place"] is False
    assert settings["shape_search"] is False
    assert settings["shape_placements"] is False and settings["pairs"] is False
    assert settings["true_position"] is False and settings["rails"] == "read"
    assert settings["kin_refit"] is True  # the two switches that are off by default
    assert settings["kin_profile"] is False and settings["onset_profile"] is True
    assert settings["witness_refit"] is False and settings["convention_profile"] is False
    assert settings["timing_regressor"] == "band"
    assert settings["line_refine"] is False and settings["joint_correlation"] is True
    assert settings["line_profile"] is True


def test_cli_reports_a_bad_file_in_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.h5"
    bad.write_text("not hdf5")
    assert main([str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "bad.h5" in err[0]


def test_cli_rejects_bad_options(recording, tmp_path, capsys):
    assert main([str(recording / "clean.h5"), "--out", str(tmp_path), "--alpha", "2"]) == 2
    assert "alpha" in capsys.readouterr().err
