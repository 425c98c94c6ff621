"""Atomic file writes: the one way tmopt puts a file on disk.

A file is written to a temporary file in the same folder, flushed to the disk and then
renamed over the target (``os.replace`` is atomic on POSIX). A process killed at any
moment therefore leaves either the previous complete file or the new complete one, never
a half-written file; a stale ``.NAME.*.tmp`` is ignored by every reader.

This module imports nothing of tmopt, so every layer may use it: the evaluation archive,
algorithm checkpoints, run outputs, sweep reports and recordings alike.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path


def atomic_write(path: str | Path, write: Callable[[str], None]) -> None:
    """Call ``write(tmp)`` on a temporary file next to ``path``, then rename it into place.

    The file gets the mode an ordinary ``open()`` would give it, ``0o666 & ~umask``
    (mkstemp's 0o600 would hide metrics, archives and tables from the collaborators of a
    shared cluster folder; a fixed mode would ignore a user who wants them private).

    Args:
        path: The file to write.
        write: Writes the whole content to the path it is given (h5py, ``write_text``, ...).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        os.chmod(tmp, 0o666 & ~current_umask())
        write(tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        _remove_quietly(tmp)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (:func:`atomic_write`)."""
    atomic_write(path, lambda tmp: Path(tmp).write_bytes(data))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def current_umask() -> int:
    """The process's umask, read without changing it where the kernel reports it
    (``/proc/self/status``, Linux >= 4.7); elsewhere set and restored at once."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # the only portable way to read it; restored on the next line
    os.umask(mask)
    return mask


def remove_stale_temporaries(folder: str | Path) -> list[Path]:
    """Delete the temporary files (``.NAME.*.tmp``) that writers killed mid-write left in
    ``folder``; return them. Call only while no other process writes there (under the
    run lock): a live writer's temporary file has the same name pattern."""
    removed = []
    for tmp in Path(folder).glob(".*.tmp"):
        if tmp.is_file():
            _remove_quietly(tmp)
            removed.append(tmp)
    return removed


def _remove_quietly(path: str | Path) -> None:
    try:
        os.remove(path)
    except OSError:
        pass
