"""python -m tmopt.design and mismatch --design-next: bad input is one line, exit 2,
before any expensive work (no diagnosis, no simulation); a report input works."""

from __future__ import annotations

import json

import pytest

import tmopt.mismatch.diagnose as diagnose_module
from tmopt.design import cli
from tmopt.mismatch.__main__ import main as mismatch_main


@pytest.fixture
def no_work(monkeypatch):
    """Any diagnosis would be expensive work: fail the test if one starts."""

    def boom(*a, **k):
        raise AssertionError("expensive work started before the input was checked")

    monkeypatch.setattr(diagnose_module, "diagnose", boom)
    monkeypatch.setattr(diagnose_module, "fit_state", boom)


@pytest.mark.parametrize("extra, word", [
    (["--tones", "9"], "--tones"),
    (["--axes", "x1,z1"], "--axes"),
    (["--axes", "x1,x1"], "--axes"),
    (["--duration", "900,300"], "--duration"),
    (["--duration", "abc"], "--duration"),
    (["--effects", "gravity"], "--effects"),
    (["--pop-size", "2"], "--pop-size"),
    (["--generations", "0"], "--generations"),
    (["--algorithm", "nsga22"], "--algorithm"),  # names the registry, "did you mean"
    (["--algorithm", "mgsaea", "--budget", "50"], "--budget"),  # below its 11 D - 1 start
    (["--budget", "0"], "--budget"),
])  # fmt: skip
def test_bad_options_one_line_exit_2(tmp_path, capsys, no_work, extra, word):
    rec = tmp_path / "r.h5"
    rec.write_bytes(b"")
    assert cli.main([str(rec), "--out", str(tmp_path / "o"), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0] and "error" in err[0]
    assert not (tmp_path / "o").exists()


def test_missing_and_unreadable_inputs(tmp_path, capsys, no_work):
    assert cli.main([str(tmp_path / "none.h5"), "--out", str(tmp_path / "o")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    bad = tmp_path / "bad.h5"
    bad.write_text("not hdf5")
    assert cli.main([str(bad), "--out", str(tmp_path / "o")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    rep = tmp_path / "report.json"
    rep.write_text(json.dumps({"something": "else"}))
    assert cli.main([str(rep), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a mismatch report" in err[0]


def test_mismatch_design_next_checks_its_options_first(tmp_path, capsys, no_work):
    rec = tmp_path / "r.h5"
    rec.write_bytes(b"")
    code = mismatch_main([str(rec), "--out", str(tmp_path / "o"), "--design-next",
                          "--tones", "0"])  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--tones" in err[0]
