"""The evaluation archive: round trip, atomic rewrite, clear errors on unusable files."""

import h5py
import numpy as np
import pytest

import tmopt.files as files_mod
from tmopt.evaluation.archive import (
    ArchiveData,
    ArchiveError,
    EvaluationArchive,
    read_archive,
)
from tmopt.files import atomic_write_text


def _rows(n: int, start: float = 0.0, failed_at: int | None = None) -> ArchiveData:
    rng = np.random.default_rng(int(start))
    failed = np.zeros(n, dtype=bool)
    reason = [""] * n
    F = rng.random((n, 2)) + start
    if failed_at is not None:
        failed[failed_at] = True
        reason[failed_at] = "evaluation raised RuntimeError: boom"
        F[failed_at] = np.nan
    return ArchiveData(X=rng.random((n, 3)), F=F, G=rng.random((n, 1)) - 0.5, failed=failed,
                       reason=reason, seed=np.full(n, 7, dtype=np.int64),
                       wall_time=np.full(n, 0.01), batch=np.zeros(n, dtype=np.int64))


def _archive(path, attrs=None):
    return EvaluationArchive(path, n_var=3, n_obj=2, n_constr=1,
                             attrs=attrs or {"config_hash": "abc", "problem": "toy"})


def test_round_trip_keeps_every_field(tmp_path):
    path = tmp_path / "archive.h5"
    arch = _archive(path)
    first, second = _rows(4, 0.0), _rows(3, 10.0, failed_at=1)
    arch.append(first)
    arch.append(second)
    data = read_archive(path)
    assert len(data) == 7
    np.testing.assert_array_equal(data.X, np.vstack([first.X, second.X]))
    np.testing.assert_array_equal(data.F, np.vstack([first.F, second.F]))  # NaN kept
    np.testing.assert_array_equal(data.G, np.vstack([first.G, second.G]))
    assert data.failed.tolist() == [False] * 5 + [True, False]
    assert data.reason[5] == "evaluation raised RuntimeError: boom"
    assert data.seed.tolist() == [7] * 7
    assert data.attrs["config_hash"] == "abc" and data.attrs["problem"] == "toy"


def test_killed_writer_leaves_previous_archive_intact(tmp_path, monkeypatch):
    path = tmp_path / "archive.h5"
    arch = _archive(path)
    arch.append(_rows(4))
    before = path.read_bytes()
    real = h5py.Group.create_dataset

    def dies_midway(self, name, *args, **kwargs):
        if name == "G":  # X and F of the new file are already written
            raise KeyboardInterrupt("killed while writing")
        return real(self, name, *args, **kwargs)

    monkeypatch.setattr(h5py.Group, "create_dataset", dies_midway)
    with pytest.raises(KeyboardInterrupt):
        arch.append(_rows(3, 5.0))
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert len(read_archive(path)) == 4
    assert not list(tmp_path.glob("*.tmp")), "the temporary file must be removed"


def test_kill_before_rename_leaves_previous_archive(tmp_path, monkeypatch):
    path = tmp_path / "archive.h5"
    arch = _archive(path)
    arch.append(_rows(2))

    def no_rename(src, dst):
        raise SystemExit("killed before the rename")

    monkeypatch.setattr(files_mod.os, "replace", no_rename)
    with pytest.raises(SystemExit):
        arch.append(_rows(2, 3.0))
    monkeypatch.undo()
    assert len(read_archive(path)) == 2


def test_stale_temporary_file_is_ignored(tmp_path):
    path = tmp_path / "archive.h5"
    _archive(path).append(_rows(2))
    (tmp_path / ".archive.h5.x1y2.tmp").write_bytes(b"half-written garbage")
    assert len(read_archive(path)) == 2


def test_corrupt_file_raises_archive_error_naming_it(tmp_path):
    path = tmp_path / "archive.h5"
    path.write_bytes(b"\x89HDF\r\n this is not really an HDF5 file")
    with pytest.raises(ArchiveError, match="archive.h5"):
        read_archive(path)


def test_missing_file_raises_archive_error(tmp_path):
    with pytest.raises(ArchiveError, match="nothing.h5"):
        read_archive(tmp_path / "nothing.h5")


def test_foreign_hdf5_file_is_refused(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as h5:
        h5.create_dataset("X", data=np.zeros((2, 2)))
    with pytest.raises(ArchiveError, match="not a tmopt archive"):
        read_archive(path)


def test_missing_dataset_and_unequal_lengths_are_refused(tmp_path):
    path = tmp_path / "archive.h5"
    _archive(path).append(_rows(3))
    with h5py.File(path, "a") as h5:
        del h5["seed"]
    with pytest.raises(ArchiveError, match="archive.h5"):
        read_archive(path)
    path2 = tmp_path / "archive2.h5"
    _archive(path2).append(_rows(3))
    with h5py.File(path2, "a") as h5:
        del h5["F"]
        h5.create_dataset("F", data=np.zeros((2, 2)))
    with pytest.raises(ArchiveError, match="unequal lengths"):
        read_archive(path2)


def test_atomic_write_text_failure_keeps_old_content(tmp_path, monkeypatch):
    path = tmp_path / "metrics.json"
    atomic_write_text(path, "old")
    monkeypatch.setattr(files_mod.os, "replace", lambda *a: (_ for _ in ()).throw(OSError()))
    with pytest.raises(OSError):
        atomic_write_text(path, "new")
    monkeypatch.undo()
    assert path.read_text() == "old"
    assert not list(tmp_path.glob("*.tmp"))


def test_noise_seeds_round_trip_pad_and_default(tmp_path):
    """Which noise realisations scored each row: kept per row; narrower batches are
    padded with -1; archives without the dataset read as 'none known' (width 0)."""
    path = tmp_path / "archive.h5"
    arch = _archive(path)
    a, b = _rows(2, 0.0), _rows(3, 10.0)
    a.noise_seeds = np.array([[0, 1, 2], [0, 1, 2]])
    b.noise_seeds = np.array([[2**52 - 1], [5], [6]])
    arch.append(a)
    arch.append(b)
    data = read_archive(path)
    assert data.noise_seeds.tolist() == [[0, 1, 2], [0, 1, 2], [2**52 - 1, -1, -1],
                                         [5, -1, -1], [6, -1, -1]]
    assert data.rows(1, 3).noise_seeds.tolist() == [[0, 1, 2], [2**52 - 1, -1, -1]]
    with h5py.File(path, "a") as h5:  # an archive written before noise seeds and checksums
        del h5["noise_seeds"], h5["batch_end"], h5["batch_sha256"]
        h5.attrs["format_version"] = 1
    assert read_archive(path).noise_seeds.shape == (5, 0)
    with pytest.raises(ValueError, match=r"noise_seeds must have shape \(2, K\)"):
        ArchiveData(**{**_rows(2).__dict__, "noise_seeds": np.zeros((3, 1))})
