"""tmopt/files.py: atomic writes respect the umask; temporaries that kills leave are removed."""

from __future__ import annotations

import os
import stat

import pytest

from tmopt.files import atomic_write_text, current_umask, remove_stale_temporaries


@pytest.fixture
def umask():
    old = os.umask(0o022)
    os.umask(old)
    yield lambda mask: os.umask(mask)
    os.umask(old)


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_written_files_get_the_mode_of_an_ordinary_open_under_the_umask(tmp_path, umask,
                                                                         mask, mode):
    umask(mask)
    assert current_umask() == mask
    atomic_write_text(tmp_path / "metrics.json", "{}")
    with open(tmp_path / "plain.txt", "w") as fh:  # what the umask gives an ordinary file
        fh.write("x")
    assert stat.S_IMODE((tmp_path / "metrics.json").stat().st_mode) == mode
    assert stat.S_IMODE((tmp_path / "plain.txt").stat().st_mode) == mode


def test_stale_temporaries_are_removed_and_nothing_else(tmp_path):
    (tmp_path / ".archive.h5.ab12cd.tmp").write_bytes(b"half")
    (tmp_path / ".metrics.json.zz.tmp").write_text("half")
    (tmp_path / "archive.h5").write_bytes(b"keep")
    (tmp_path / "run.lock").write_text("keep")
    removed = remove_stale_temporaries(tmp_path)
    assert sorted(p.name for p in removed) == [".archive.h5.ab12cd.tmp", ".metrics.json.zz.tmp"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["archive.h5", "run.lock"]
