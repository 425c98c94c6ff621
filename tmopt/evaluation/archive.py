"""Append-only store of every real evaluation, written atomically as it grows.

Every batch of real evaluations is appended and the whole archive is rewritten
atomically (:mod:`tmopt.files`: a temporary file renamed over the old one), so a run
killed at any moment leaves either the previous complete archive or the new complete
one, never a half-written file. Rewriting is cheap here: even 10 000 evaluations of 30
variables are a few MB.

The archive also carries the hash of the configuration that produced it, so a resumed
run can refuse an archive that belongs to a different experiment, and a SHA-256 checksum
of every batch over all its per-row datasets (X, F, G and the evaluation metadata: every
field of :class:`ArchiveData` but ``attrs``, so a column added later is covered without
touching the checksum), so a flipped bit or a zeroed row on disk is found when the
archive is read (docs/decisions.md, "Archive checksums").
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, fields
from pathlib import Path

import h5py
import numpy as np

from tmopt.files import atomic_write

FORMAT = "tmopt-archive"
#: 1: round one, no checksums (still read; checked only by replay); 2: batch checksums.
FORMAT_VERSION = 2
#: Per batch (in row order): the row where it ends and the SHA-256 of its rows.
CHECKSUM_END = "batch_end"
CHECKSUM_SHA = "batch_sha256"
_CHECKSUM_DATASETS = (CHECKSUM_END, CHECKSUM_SHA)


class ArchiveError(RuntimeError):
    """The archive on disk is unreadable or belongs to another experiment."""


@dataclass
class ArchiveData:
    """All real evaluations so far, one row per design.

    F and G hold the raw values returned by the problem (NaN where the design failed);
    ``failed`` marks designs whose evaluation raised, returned non-finite values or
    timed out, and ``reason`` says why ("" when it did not fail).  ``seed`` is the run's
    seed; ``noise_seeds`` (n, K) the noise realisations that scored each row (a noisy
    problem's ``out["noise_seeds"]``; -1 pads, K = 0 for problems without noise).
    """

    X: np.ndarray
    F: np.ndarray
    G: np.ndarray
    failed: np.ndarray
    reason: list[str]
    seed: np.ndarray
    wall_time: np.ndarray
    batch: np.ndarray
    attrs: dict = field(default_factory=dict)
    noise_seeds: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.X)
        seeds = np.zeros((n, 0)) if self.noise_seeds is None else np.asarray(self.noise_seeds)
        if seeds.ndim == 1 and len(seeds) == n:
            seeds = seeds[:, None]
        if seeds.ndim != 2 or len(seeds) != n:
            raise ValueError(f"noise_seeds must have shape ({n}, K); got {seeds.shape}")
        self.noise_seeds = seeds.astype(np.int64)

    @classmethod
    def empty(cls, n_var: int, n_obj: int, n_constr: int) -> ArchiveData:
        return cls(
            X=np.zeros((0, n_var)),
            F=np.zeros((0, n_obj)),
            G=np.zeros((0, n_constr)),
            failed=np.zeros(0, dtype=bool),
            reason=[],
            seed=np.zeros(0, dtype=np.int64),
            wall_time=np.zeros(0),
            batch=np.zeros(0, dtype=np.int64),
        )

    def __len__(self) -> int:
        return len(self.X)

    def append(self, other: ArchiveData) -> None:
        self.X = np.vstack([self.X, other.X])
        self.F = np.vstack([self.F, other.F])
        self.G = np.vstack([self.G, other.G])
        self.failed = np.concatenate([self.failed, other.failed])
        self.reason = self.reason + list(other.reason)
        self.seed = np.concatenate([self.seed, other.seed])
        self.wall_time = np.concatenate([self.wall_time, other.wall_time])
        self.batch = np.concatenate([self.batch, other.batch])
        width = max(self.noise_seeds.shape[1], other.noise_seeds.shape[1])
        self.noise_seeds = np.vstack([_padded(self.noise_seeds, width),
                                      _padded(other.noise_seeds, width)])

    def rows(self, start: int, stop: int) -> ArchiveData:
        return ArchiveData(
            X=self.X[start:stop],
            F=self.F[start:stop],
            G=self.G[start:stop],
            failed=self.failed[start:stop],
            reason=self.reason[start:stop],
            seed=self.seed[start:stop],
            wall_time=self.wall_time[start:stop],
            batch=self.batch[start:stop],
            attrs=dict(self.attrs),
            noise_seeds=self.noise_seeds[start:stop],
        )


def _padded(seeds: np.ndarray, width: int) -> np.ndarray:
    """``seeds`` (n, k) widened to (n, width) with -1 ("no seed")."""
    out = np.full((len(seeds), width), -1, dtype=np.int64)
    out[:, :seeds.shape[1]] = seeds
    return out


class EvaluationArchive:
    """The on-disk archive of one run (``archive.h5`` in the run folder)."""

    def __init__(self, path: str | Path, n_var: int, n_obj: int, n_constr: int,
                 attrs: dict | None = None) -> None:
        self.path = Path(path)
        self.attrs = dict(attrs or {})
        self.data = ArchiveData.empty(n_var, n_obj, n_constr)
        self.data.attrs = self.attrs

    def __len__(self) -> int:
        return len(self.data)

    def append(self, rows: ArchiveData) -> None:
        """Append a batch and persist the whole archive atomically."""
        self.data.append(rows)
        self.save()

    def save(self) -> None:
        write_archive(self.path, self.data, self.attrs)


@dataclass(frozen=True)
class DamagedBatch:
    """A batch whose rows ``start .. stop - 1`` no longer match their checksum."""

    start: int
    stop: int
    columns: tuple[str, ...]  # the datasets whose bytes differ ("" if unknown)

    def describe(self) -> str:
        cols = ", ".join(self.columns) if self.columns else "checksum record"
        return f"rows {self.start}-{self.stop - 1} ({cols})"


def row_columns(data: ArchiveData) -> dict[str, np.ndarray]:
    """Every per-row dataset of ``data`` (first axis = rows), named as in the file."""
    cols = {}
    for f in fields(ArchiveData):
        if f.name == "attrs":
            continue
        value = getattr(data, f.name)
        if value is None:
            continue
        cols[f.name] = _canonical(np.asarray(value) if f.name != "reason"
                                  else np.array(list(value), dtype=object))
    return cols


def _canonical(col: np.ndarray) -> np.ndarray:
    """Strings as Python ``str`` (h5py reads them back as bytes); numbers as they are."""
    if col.dtype.kind in "OSU":
        return np.array([v.decode() if isinstance(v, bytes) else str(v) for v in col],
                        dtype=object)
    return col


def batch_bounds(batch: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of equal values in the ``batch`` column."""
    if len(batch) == 0:
        return []
    cuts = np.flatnonzero(np.diff(np.asarray(batch)) != 0) + 1
    edges = [0, *cuts.tolist(), len(batch)]
    return list(zip(edges[:-1], edges[1:]))


def batch_checksum(cols: dict[str, np.ndarray], start: int, stop: int) -> dict[str, str]:
    """Per column, SHA-256 (128 bits shown) of rows ``start:stop`` (position, dtype, shape,
    values), so a damaged batch can be reported with the datasets that changed."""
    return {name: _column_digest(f"{start}:{stop}|{name}", cols[name][start:stop])
            for name in sorted(cols)}


def _column_digest(label: str, part: np.ndarray) -> str:
    h = hashlib.sha256(f"{label}|{part.dtype.kind}|{part.shape}".encode())
    if part.dtype.kind == "O":
        for v in part:
            b = str(v).encode()
            h.update(len(b).to_bytes(8, "little") + b)
    else:
        h.update(np.ascontiguousarray(part, dtype=part.dtype.newbyteorder("<")).tobytes())
    return h.hexdigest()[:32]


def damaged_batches(cols: dict[str, np.ndarray], ends, sums) -> list[DamagedBatch]:
    """The batches whose rows no longer match the stored checksums (``sums``: one JSON
    object per batch, column -> digest), in row order."""
    damaged, start = [], 0
    n = min((len(c) for c in cols.values()), default=0)
    for end, record in zip(ends, sums):
        stop = min(int(end), n)
        if stop <= start:
            break
        try:
            want = json.loads(record.decode() if isinstance(record, bytes) else record)
        except ValueError:
            want = {}
        got = batch_checksum(cols, start, stop)
        changed = sorted(k for k in set(want) | set(got) if want.get(k) != got.get(k))
        if changed or int(end) > n:
            damaged.append(DamagedBatch(start, stop, tuple(changed)))
        start = stop
    if start < n:  # rows after the last checksummed batch: nothing vouches for them
        damaged.append(DamagedBatch(start, n, ()))
    return damaged


def write_archive(path: Path, data: ArchiveData, attrs: dict) -> None:
    """Write ``data`` and ``attrs`` to ``path`` atomically (:func:`tmopt.files.atomic_write`)."""
    atomic_write(path, lambda tmp: _write_h5(tmp, data, attrs))


def _write_h5(tmp: str, data: ArchiveData, attrs: dict) -> None:
    with h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION
        for key, value in attrs.items():
            h5.attrs[key] = value
        h5.create_dataset("X", data=data.X)
        h5.create_dataset("F", data=data.F)
        h5.create_dataset("G", data=data.G)
        h5.create_dataset("failed", data=data.failed)
        h5.create_dataset("reason", data=np.array(data.reason, dtype=h5py.string_dtype()))
        h5.create_dataset("seed", data=data.seed)
        h5.create_dataset("wall_time", data=data.wall_time)
        h5.create_dataset("batch", data=data.batch)
        h5.create_dataset("noise_seeds", data=data.noise_seeds)
        cols = row_columns(data)
        bounds = batch_bounds(data.batch)
        h5.create_dataset(CHECKSUM_END, data=np.array([b for _, b in bounds], dtype=np.int64))
        h5.create_dataset(CHECKSUM_SHA, data=np.array(
            [json.dumps(batch_checksum(cols, a, b)) for a, b in bounds],
            dtype=h5py.string_dtype()))


def has_checksums(data: ArchiveData) -> bool:
    """Whether ``data`` was read from an archive with batch checksums (format >= 2)."""
    return int(data.attrs.get("format_version", 1)) >= 2


class ArchiveDamaged(ArchiveError):
    """Rows of the archive no longer match their checksums (see :attr:`damaged`)."""

    def __init__(self, path: Path, damaged: list[DamagedBatch]) -> None:
        self.damaged = damaged
        rows = sum(d.stop - d.start for d in damaged)
        super().__init__(f"{path}: {rows} rows changed on disk since they were written "
                         f"(checksum mismatch: {'; '.join(d.describe() for d in damaged)})")


def read_archive(path: str | Path) -> ArchiveData:
    """Read an archive whose every row matches its checksum.

    Raises:
        ArchiveDamaged: rows changed since written (a corrupt disk, a careless edit).
        ArchiveError: the file is unusable (message names it).
    """
    data, damaged = read_archive_checked(path)
    if damaged:
        raise ArchiveDamaged(Path(path), damaged)
    return data


def read_archive_checked(path: str | Path) -> tuple[ArchiveData, list[DamagedBatch]]:
    """Read an archive and list the batches that fail their checksums (none are checked
    in a format-1 archive, which has none: round one's archives are read as they are)."""
    path = Path(path)
    names = [f.name for f in fields(ArchiveData) if f.name != "attrs"]
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != FORMAT:
                raise ArchiveError(f"{path}: not a tmopt archive (attribute 'format' is "
                                   f"{h5.attrs.get('format')!r}, expected {FORMAT!r})")
            attrs = {k: _plain(v) for k, v in h5.attrs.items()}
            stored = {name: h5[name][()] for name in h5 if name not in _CHECKSUM_DATASETS}
            checksums = [h5[name][()] for name in _CHECKSUM_DATASETS] \
                if all(name in h5 for name in _CHECKSUM_DATASETS) else None
        missing = [n for n in ("X", "F", "G", "failed", "reason", "seed", "wall_time", "batch")
                   if n not in stored]
        if missing:
            raise KeyError(f"dataset {missing[0]!r} is missing")
        cols = {k: _canonical(v) for k, v in stored.items()}
        sizes = {len(v) for v in cols.values()}
        if len(sizes) != 1:
            raise ArchiveError(f"{path}: datasets have unequal lengths {sorted(sizes)}")
        data = ArchiveData(**{k: v for k, v in cols.items() if k in names}, attrs=attrs)
        data.failed = data.failed.astype(bool)
        data.reason = [str(r) for r in data.reason]
    except ArchiveError:
        raise
    except Exception as exc:  # noqa: BLE001 - h5py reports a damaged file in many types
        raise ArchiveError(f"{path}: cannot read the evaluation archive "
                           f"({type(exc).__name__}: {exc})") from exc
    damaged = damaged_batches(cols, *checksums) if checksums is not None else []
    return data, damaged


def _plain(value):
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value
