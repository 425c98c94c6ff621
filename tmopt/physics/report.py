"""Small helpers shared by the paper-reproduction scripts in experiments/."""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = ["output_dir", "write_csv", "write_rows"]


def output_dir(name: str, override: str | None = None) -> Path:
    """``experiments/out/<name>/`` (git-ignored) unless ``override`` is given; created."""
    root = Path(__file__).resolve().parents[2] / "experiments" / "out" / name
    path = Path(override) if override else root
    path.mkdir(parents=True, exist_ok=True)
    return path


def write_csv(path: Path, columns: Mapping[str, np.ndarray]) -> None:
    """Equal-length 1-D columns -> CSV with a header row (full float precision)."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n]) for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")


def write_rows(path: Path, rows: Sequence[Mapping[str, object]]) -> None:
    """List of dicts (same keys) -> CSV."""
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
