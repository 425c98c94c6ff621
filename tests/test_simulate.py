"""``python -m tmopt.simulate``: numbers, recording and plot; bad input is one line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from tmopt.physics.recording import read_recording
from tmopt.simulate import Settings, main, run, summary


def test_writes_a_valid_recording_and_plot_and_prints_the_numbers(tmp_path, capsys):
    out = tmp_path / "run.h5"
    assert main(["--duration", "300", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| convergence_time s |" in printed and "| M  |" in printed
    rec = read_recording(out)
    assert rec.sample_rate == 10.0 and len(rec.time) == 3000
    assert (tmp_path / "run.png").stat().st_size > 10_000
    # the recording holds what was simulated: x1 follows the paper's Fig. 6 reference
    ref = 5e-5 * np.sin(2 * np.pi * rec.time / 300)
    assert np.max(np.abs(rec["ref_x1"] - ref)) < 1e-12


def test_summary_is_the_simulators_objectives():
    result = run(Settings(duration=300.0), seed=4)
    numbers = summary(result)
    assert set(numbers) == {"k1xx", "k2xx"}
    k1 = numbers["k1xx"]
    assert k1["M"] == k1["convergence_time"] / 60 + 1e10 * k1["convergence_accuracy"]


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["--excitation", "bogus:1", "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tmopt.simulate: error: excitation 'bogus:1'") and "\n" not in err
    assert main(["--duration", "-5", "--out", str(tmp_path / "x.h5")]) == 2
    assert "duration" in capsys.readouterr().err


def test_the_command_is_physics_only(tmp_path):
    # python -m tmopt.simulate runs without loading any module of the mismatch tool
    code = ("import sys\nfrom tmopt.simulate import main\n"
            f"rc = main(['--duration', '60', '--out', {str(tmp_path / 'r.h5')!r}])\n"
            "print(rc, sorted(m for m in sys.modules if m.startswith('tmopt.mismatch')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)  # fmt: skip
    assert done.stdout.strip().splitlines()[-1] == "0 []"
