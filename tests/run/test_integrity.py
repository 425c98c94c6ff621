"""Archive integrity (issue 20 part 2): what changed on disk is found, said and repaired.

Every corruption is made to the archive of a run whose result is known; a resume must end
with exactly that result (found damage evaluated again, with a warning naming the rows) or
refuse in one line. A different best.json after exit 0 would be a silent wrong answer.
"""

from __future__ import annotations

import json
import logging
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from tmopt.algorithms.nsga2 import NSGA2
from tmopt.evaluation.archive import (
    CHECKSUM_END,
    CHECKSUM_SHA,
    ArchiveDamaged,
    ArchiveError,
    read_archive,
    read_archive_checked,
)
from tmopt.problems.suites import PymooBenchmark
from tmopt.run.runner import FolderOfAnotherRun, run_optimisation

REPO = Path(__file__).resolve().parents[2]


def _run(outdir: Path, seed: int = 3, config_hash: str = "h3"):
    return run_optimisation(PymooBenchmark("mw1", n_var=4), NSGA2(pop_size=10), budget=60,
                            seed=seed, outdir=outdir, config_hash=config_hash, progress=False,
                            plots=False)


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """A finished run: 6 batches of 10 evaluations."""
    folder = tmp_path_factory.mktemp("reference")
    _run(folder)
    return folder


def _copy(reference: Path, tmp_path: Path, finished: bool = False) -> Path:
    run = tmp_path / "run"
    shutil.copytree(reference, run)
    if not finished:
        (run / "metrics.json").unlink()  # killed after its last batch
    return run


def _chosen_index(run: Path) -> int:
    return json.loads((run / "best.json").read_text())["index"]


def _outputs(run: Path) -> dict:
    return {name: (run / name).read_text() for name in ("best.json", "pareto.csv")}


def _same_rows(a, b) -> None:
    for name in ("X", "F", "G", "failed", "seed", "batch"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.reason == b.reason


# ---- corruptions of one dataset: generated over every per-row dataset ---------------------
def _flip_bit(values: np.ndarray, row: int) -> np.ndarray:
    """The smallest possible change: the lowest bit of the row's first byte."""
    out = values.copy()
    if out.dtype == bool:
        out[row] = ~out[row]
    elif out.dtype.kind == "O":  # strings (reason): an empty one gains a byte
        text = bytearray(out[row] or b"\x00")
        text[0] ^= 1
        out[row] = bytes(text)
    else:
        np.atleast_1d(out[row:row + 1].reshape(-1)).view(np.uint8)[0] ^= 1
    return out


CORRUPTIONS = {
    "flip one bit": _flip_bit,
    "zero the row": lambda v, r: _set(v, r, 0),
    "garbage row": lambda v, r: _set(v, r, 12345),
}


def _set(values: np.ndarray, row: int, what) -> np.ndarray:
    out = values.copy()
    if out.dtype.kind == "O":
        out[row] = b"" if what == 0 else b"garbage"
    else:
        out[row] = what
    return out


def _corrupt(archive: Path, dataset: str, row: int, how: str) -> None:
    with h5py.File(archive, "r+") as h5:
        values = h5[dataset][()]
        new = CORRUPTIONS[how](values, row)
        if np.array_equal(new, values):  # e.g. zeroing a row that is zero already
            new = CORRUPTIONS["garbage row"](values, row)
        h5[dataset][...] = new


def _row_datasets(archive: Path) -> list[str]:
    with h5py.File(archive, "r") as h5:
        n = len(h5["X"])
        # a dataset whose rows hold no values (noise_seeds of a noiseless problem: width 0)
        # cannot be damaged; its checksum is tested in test_a_column_of_another_branch_...
        return sorted(k for k in h5 if k not in (CHECKSUM_END, CHECKSUM_SHA)
                      and len(h5[k]) == n and h5[k][()][:1].size)


def test_a_flipped_bit_in_f_of_the_chosen_design_is_found_and_its_batch_evaluated_again(
        reference, tmp_path, caplog):
    run = _copy(reference, tmp_path)
    chosen = _chosen_index(reference)
    _corrupt(run / "archive.h5", "F", chosen, "flip one bit")
    with pytest.raises(ArchiveDamaged, match=f"rows {chosen // 10 * 10}-"):
        read_archive(run / "archive.h5")
    with caplog.at_level(logging.WARNING):
        again = _run(run)
    batch = chosen // 10 * 10
    assert f"rows {batch}-{batch + 9} (F) changed on disk" in caplog.text
    assert _outputs(run) == _outputs(reference)
    _same_rows(again.archive, read_archive(reference / "archive.h5"))
    _same_rows(read_archive(run / "archive.h5"), read_archive(reference / "archive.h5"))


def test_every_corruption_of_every_per_row_dataset_is_detected_and_repaired(reference,
                                                                            tmp_path, caplog):
    """Generated: each per-row dataset of the file (so a column added later is included)
    x three kinds of damage x two rows. Each must be detected, named, and the resume must
    end with the uninterrupted result."""
    datasets = _row_datasets(reference / "archive.h5")
    assert {"X", "F", "G", "failed", "reason", "seed", "wall_time", "batch"} <= set(datasets)
    cases = [(d, how, row) for d in datasets for how in CORRUPTIONS for row in (0, 37)]
    detected = 0
    for i, (dataset, how, row) in enumerate(cases):
        run = _copy(reference, tmp_path / str(i))
        _corrupt(run / "archive.h5", dataset, row, how)
        _, damaged = read_archive_checked(run / "archive.h5")
        assert [(d.start, d.stop) for d in damaged] == [(row // 10 * 10, row // 10 * 10 + 10)], \
            (dataset, how, row)
        assert damaged[0].columns == (dataset,)
        detected += 1
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            _run(run)
        assert "changed on disk" in caplog.text
        assert _outputs(run) == _outputs(reference), (dataset, how, row)
    print(f"\n{detected} of {len(cases)} corruptions detected and repaired "
          f"({len(datasets)} datasets); 0 silent")


def test_a_column_of_another_branch_is_covered_without_touching_the_checksum(tmp_path):
    """noise_seeds (issue 18) came after the checksums were written: covered generically."""
    from tmopt.evaluation.archive import ArchiveData, EvaluationArchive

    path = tmp_path / "archive.h5"
    archive = EvaluationArchive(path, n_var=2, n_obj=1, n_constr=0)
    for b in range(3):
        archive.append(ArchiveData(
            X=np.full((2, 2), float(b)), F=np.ones((2, 1)), G=np.zeros((2, 0)),
            failed=np.zeros(2, bool), reason=["", ""], seed=np.zeros(2, np.int64),
            wall_time=np.ones(2), batch=np.full(2, b), noise_seeds=np.array([[7], [8]])))
    assert read_archive(path).noise_seeds.tolist() == [[7], [8]] * 3
    _corrupt(path, "noise_seeds", 3, "flip one bit")
    _, damaged = read_archive_checked(path)
    assert [(d.start, d.stop, d.columns) for d in damaged] == [(2, 4, ("noise_seeds",))]


def test_a_damaged_checksum_record_is_damage_too(reference, tmp_path):
    run = _copy(reference, tmp_path)
    with h5py.File(run / "archive.h5", "r+") as h5:
        sums = h5[CHECKSUM_SHA][()]
        sums[2] = b"{}"
        h5[CHECKSUM_SHA][...] = sums
    _, damaged = read_archive_checked(run / "archive.h5")
    assert [(d.start, d.stop) for d in damaged] == [(20, 30)]
    _run(run)
    assert _outputs(run) == _outputs(reference)


def test_random_byte_flips_anywhere_in_the_file_never_change_the_result(reference, tmp_path):
    """Whatever byte is changed: the resume ends with the reference result (damage found
    and re-evaluated, or the file unreadable, kept aside and the run made again), or the
    byte held nothing that is read."""
    size = (reference / "archive.h5").stat().st_size
    rng = np.random.default_rng(20)
    outcomes = {"damaged rows re-evaluated": 0, "unreadable, started over": 0,
                "byte not read": 0}
    for i, offset in enumerate(rng.integers(0, size, 40)):
        run = _copy(reference, tmp_path / str(i))
        raw = bytearray((run / "archive.h5").read_bytes())
        raw[offset] ^= 0xFF
        (run / "archive.h5").write_bytes(bytes(raw))
        try:
            _, damaged = read_archive_checked(run / "archive.h5")
            kind = "damaged rows re-evaluated" if damaged else "byte not read"
        except ArchiveError:
            kind = "unreadable, started over"
        if kind == "byte not read":
            _same_rows(read_archive(run / "archive.h5"), read_archive(reference / "archive.h5"))
        outcomes[kind] += 1
        _run(run)
        assert _outputs(run) == _outputs(reference), (offset, kind)
        if kind == "unreadable, started over":
            assert (run / "archive.h5.unreadable").exists()
    print(f"\nrandom byte flips: {outcomes}; 0 silent")


# ---- a finished run whose archive is gone --------------------------------------------------
@pytest.mark.parametrize("damage", ["deleted", "truncated", "damaged"])
def test_a_finished_run_whose_archive_is_gone_is_run_again_not_failed_forever(reference,
                                                                              tmp_path, damage):
    run = _copy(reference, tmp_path, finished=True)
    archive = run / "archive.h5"
    if damage == "deleted":
        archive.unlink()
    elif damage == "truncated":
        archive.write_bytes(archive.read_bytes()[: archive.stat().st_size // 2])
    else:
        _corrupt(archive, "F", 5, "flip one bit")
    result = _run(run)
    assert not result.skipped
    assert _outputs(run) == _outputs(reference)
    _same_rows(read_archive(archive), read_archive(reference / "archive.h5"))
    assert _run(run).skipped  # and now it is simply complete


# ---- old archives --------------------------------------------------------------------------
def test_a_round_one_archive_without_checksums_still_resumes(reference, tmp_path):
    run = _copy(reference, tmp_path)
    with h5py.File(run / "archive.h5", "r+") as h5:  # what round one wrote
        del h5[CHECKSUM_END], h5[CHECKSUM_SHA]
        h5.attrs["format_version"] = 1
    data, damaged = read_archive_checked(run / "archive.h5")
    assert damaged == [] and len(data) == 60
    again = _run(run)
    assert again.resumed_from == 60
    assert _outputs(run) == _outputs(reference)
    with h5py.File(run / "archive.h5", "r") as h5:  # the next write adds the checksums
        assert h5.attrs["format_version"] == 2 and len(h5[CHECKSUM_SHA]) == 6


# ---- a run of another configuration --------------------------------------------------------
def test_a_run_of_another_seed_is_refused_and_leaves_the_folder_untouched(reference, tmp_path):
    run = _copy(reference, tmp_path, finished=True)
    before = {p.name: p.read_bytes() for p in run.iterdir()}
    with pytest.raises(FolderOfAnotherRun, match="resume=false"):
        _run(run, seed=4, config_hash="h4")
    (run / "metrics.json").unlink()  # unfinished: the archive says whose it is
    before.pop("metrics.json")
    with pytest.raises(FolderOfAnotherRun, match="archive of configuration h3"):
        _run(run, seed=4, config_hash="h4")
    assert {p.name: p.read_bytes() for p in run.iterdir()} == before


def test_the_command_line_refuses_seed_4_in_seed_3s_folder_before_writing_anything(tmp_path):
    run = tmp_path / "run"
    args = [sys.executable, "-m", "tmopt", "problem=mw1", "algorithm=nsga2", "budget=20",
            "algorithm.pop_size=10", "progress=false", "plots=false", f"hydra.run.dir={run}"]
    first = subprocess.run([*args, "seed=3"], capture_output=True, text=True, cwd=REPO)
    assert first.returncode == 0, first.stderr
    files = {p.relative_to(run): p.read_bytes() for p in run.rglob("*") if p.is_file()}
    second = subprocess.run([*args, "seed=4"], capture_output=True, text=True, cwd=REPO)
    assert second.returncode == 2
    lines = second.stderr.strip().splitlines()
    assert len(lines) == 1 and "holds a finished run of configuration" in lines[0], lines
    assert {p.relative_to(run): p.read_bytes() for p in run.rglob("*") if p.is_file()} == files


def test_temporary_files_left_by_a_kill_are_removed_when_the_run_starts(reference, tmp_path):
    run = _copy(reference, tmp_path)
    (run / ".archive.h5.k1ll3d.tmp").write_bytes(b"half an archive")
    (run / ".metrics.json.x.tmp").write_text("{")
    _run(run)
    assert not list(run.glob(".*.tmp"))
    assert _outputs(run) == _outputs(reference)
