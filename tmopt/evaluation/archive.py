"""Append-only store of every real evaluation, written atomically as it grows.

Every batch of real evaluations is appended and the whole archive is rewritten
atomically (:mod:`tmopt.files`: a temporary file renamed over the old one), so a run
killed at any moment leaves either the previous complete archive or the new complete
one, never a half-written file. Rewriting is cheap here: even 10 000 evaluations of 30
variables are a few MB.

The archive also carries the hash of the configuration that produced it, so a resumed
run can refuse an archive that belongs to a different experiment.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from tmopt.files import atomic_write

FORMAT = "tmopt-archive"
FORMAT_VERSION = 1


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


def read_archive(path: str | Path) -> ArchiveData:
    """Read an archive; raise :class:`ArchiveError` naming the file if it is unusable."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as h5:
            if h5.attrs.get("format") != FORMAT:
                raise ArchiveError(f"{path}: not a tmopt archive (attribute 'format' is "
                                   f"{h5.attrs.get('format')!r}, expected {FORMAT!r})")
            attrs = {k: _plain(v) for k, v in h5.attrs.items()}
            data = ArchiveData(
                X=h5["X"][()],
                F=h5["F"][()],
                G=h5["G"][()],
                failed=h5["failed"][()].astype(bool),
                reason=[r.decode() if isinstance(r, bytes) else str(r) for r in h5["reason"][()]],
                seed=h5["seed"][()],
                wall_time=h5["wall_time"][()],
                batch=h5["batch"][()],
                attrs=attrs,
                # archives written before noise seeds were recorded: none known
                noise_seeds=h5["noise_seeds"][()] if "noise_seeds" in h5
                else np.zeros((len(h5["X"]), 0), dtype=np.int64),
            )
    except ArchiveError:
        raise
    except (OSError, KeyError, ValueError) as exc:
        raise ArchiveError(f"{path}: cannot read the evaluation archive ({exc})") from exc
    n = len(data.X)
    sizes = {len(data.F), len(data.G), len(data.failed), len(data.reason), len(data.seed),
             len(data.wall_time), len(data.batch), len(data.noise_seeds)}
    if sizes != {n}:
        raise ArchiveError(f"{path}: datasets have unequal lengths {sorted(sizes)}")
    return data


def _plain(value):
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value
