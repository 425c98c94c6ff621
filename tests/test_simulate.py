"""``python -m tmopt.simulate``: numbers, recording and plot; bad input is one line."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from tmopt.physics.excitation import ramp_window
from tmopt.physics.recording import read_recording
from tmopt.simulate import ROWS, Settings, main, run, summary

JSON_KEYS = {"convergence_time", "convergence_accuracy", "final_accuracy", "M", "max_abs_x",
             "max_tracking_error", "steady_tracking_error", "eq20"}  # fmt: skip


def test_writes_a_valid_recording_and_plot_and_prints_the_numbers(tmp_path, capsys):
    out = tmp_path / "run.h5"
    assert main(["--duration", "300", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| convergence_time s |" in printed and "| M  |" in printed
    assert "| max_abs_x m |" in printed and "| eq20_motion  |" in printed
    rec = read_recording(out)
    assert rec.sample_rate == 10.0 and len(rec.time) == 3000
    assert (tmp_path / "run.png").stat().st_size > 10_000
    # the recording holds what was simulated: x1 follows the paper's Fig. 6 reference,
    # ramped in over the default 90 s
    ref = 5e-5 * np.sin(2 * np.pi * rec.time / 300) * ramp_window(rec.time, 90.0)
    assert np.max(np.abs(rec["ref_x1"] - ref)) < 1e-12


def test_json_holds_every_printed_number_per_test_mass(tmp_path, capsys):
    out, js = tmp_path / "run.h5", tmp_path / "run.json"
    args = ["--duration", "300", "--out", str(out), "--ramp-in", "0", "--y-axes", "round1",
            "--rls-columns", "all", "--json", str(js)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    data = json.loads(js.read_text())
    for tm in ("TM1", "TM2"):
        assert JSON_KEYS <= set(data[tm])
    for key, unit, fmt in ROWS:  # every printed row is the JSON's numbers, formatted
        a, b = data["TM1"][key], data["TM2"][key]
        assert f"| {key} {unit} | {a:{fmt}} | {b:{fmt}} |" in printed
    s = data["settings"]
    assert s["ramp_in"] == 0.0 and s["fb_bias"] == [1e-10, 1e-10] and len(s["rls_columns"]) == 5
    # no ramp: the start-up transient takes TM1 past its 5e-5 m reference
    assert data["TM1"]["max_abs_x"] > 5e-5 and data["TM1"]["eq20"]["motion"] < 0
    result = run(Settings(duration=300.0), seed=0, ramp_in=0.0, y_axes="round1",
                 rls_columns="all")  # fmt: skip
    assert data["TM1"]["max_abs_x"] == pytest.approx(result.max_abs_position[0, 0], rel=1e-12)


def test_summary_is_the_simulators_objectives():
    result = run(Settings(duration=300.0), seed=4)
    numbers = summary(result)
    assert set(numbers) == {"TM1", "TM2"} and numbers["TM1"]["parameter"] == "k1xx"
    k1 = numbers["TM1"]
    assert k1["M"] == k1["convergence_time"] / 60 + 1e10 * k1["convergence_accuracy"]
    assert k1["max_abs_x"] == result.max_abs_position[0, 0]
    assert k1["eq20_motion"] == pytest.approx(k1["max_abs_x"] / 4e-4 - 1)


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["--excitation", "bogus:1", "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tmopt.simulate: error: excitation 'bogus:1'") and "\n" not in err
    assert main(["--duration", "-5", "--out", str(tmp_path / "x.h5")]) == 2
    assert "duration" in capsys.readouterr().err
    assert main(["--ramp-in", "-1", "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert "ramp_in must be finite and in [0, inf) s" in err and "\n" not in err
    # the rescaled 10 Hz controller is unstable below 0.95 Hz: refused before simulating
    assert main(["--sample-rate", "0.5", "--duration", "1000", "--out",
                 str(tmp_path / "x.h5")]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert "sample_rate must be finite and in [1, inf) Hz" in err and "\n" not in err


def test_an_output_it_cannot_write_is_refused_before_simulating(tmp_path, capsys):
    assert main(["--duration", "60", "--out", str(tmp_path / "x.txt")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"tmopt.simulate: error: --out {tmp_path / 'x.txt'}: unknown recording "
                   "extension '.txt'; use .h5, .hdf5 or .csv")
    assert not list(tmp_path.iterdir())  # nothing simulated, nothing written


def test_the_command_is_physics_only(tmp_path):
    # python -m tmopt.simulate runs without loading any module of the mismatch tool
    code = ("import sys\nfrom tmopt.simulate import main\n"
            f"rc = main(['--duration', '60', '--out', {str(tmp_path / 'r.h5')!r}])\n"
            "print(rc, sorted(m for m in sys.modules if m.startswith('tmopt.mismatch')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)  # fmt: skip
    assert done.stdout.strip().splitlines()[-1] == "0 []"
