"""Recordings of the two-test-mass closed loop: read, write and validate (format version 1).

A recording is what a diagnosis sees: uniformly sampled channels of one run plus the few
attributes needed to interpret them (sample rate and the nominal geometry of Sec. 2.1).
Format, units and every check are specified in ``docs/recording-format.md``; the physical
range bounds are :data:`CHANNEL_SPECS`.  Two containers hold the same content:

* HDF5 (``.h5`` / ``.hdf5``): root attributes + one 1-D float64 dataset per channel;
* CSV (``.csv``) with a header of channel names, plus a JSON sidecar (same stem,
  ``.json``) holding the attributes.

Repairs (documented, never silent): NaN samples are *masked* (``Recording.valid`` is False
there and the NaN stays in the array, so a consumer that ignores the mask fails loudly),
and rows missing from an otherwise uniform time grid are re-inserted as NaN rows and masked
the same way.  Every other defect raises :class:`RecordingError` naming the file and the
channel or attribute.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import h5py
import numpy as np

from tmopt.files import atomic_write
from tmopt.physics.geometry import Geometry

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "AXES",
    "REQUIRED_CHANNELS",
    "OPTIONAL_CHANNELS",
    "ROTATION_CHANNELS",
    "CHANNEL_SPECS",
    "ChannelSpec",
    "Gap",
    "Recording",
    "RecordingError",
    "read_recording",
    "write_recording",
    "validate",
    "recording_from_simulation",
]

FORMAT = "tmopt-recording"
FORMAT_VERSION = 1

#: Axis order used everywhere: TM1 x in frame a, TM2 x in frame b, then the y axes.
AXES: tuple[str, ...] = ("x1", "x2", "y1", "y2")

REQUIRED_CHANNELS: tuple[str, ...] = (
    ("time",) + AXES + tuple(f"acc_{a}" for a in AXES) + tuple(f"force_{a}" for a in AXES)
)
#: Spacecraft angular rate and acceleration (frame s): all six or none.
ROTATION_CHANNELS: tuple[str, ...] = tuple(
    f"sc_omega{d}_{c}" for d in ("", "_dot") for c in "xyz"
)
OPTIONAL_CHANNELS: tuple[str, ...] = ("ref_x1", "ref_x2") + ROTATION_CHANNELS

#: Time-grid tolerance as a fraction of the sampling interval (also the allowed relative
#: mismatch between ``sample_rate`` and the median time step).
GRID_TOLERANCE = 1e-3
#: Allowed mismatch |alpha - (phi2 - phi1)| [rad] (attributes written with ~7 digits pass).
ANGLE_TOLERANCE = 1e-6


#: Sidecar key holding the SHA-256 of the CSV bytes (written by tmopt, checked if present).
CSV_CHECKSUM = "csv_sha256"


class RecordingError(ValueError):
    """A recording is unreadable or violates the format; the message names file and channel."""


@dataclass(frozen=True)
class ChannelSpec:
    """Unit and physical range bound ``|value| <= bound`` of one channel family."""

    unit: str
    bound: float
    meaning: str


# Bounds are generous physical limits, not expectations: they exist to catch wrong units
# (mm or um instead of m, nm s^-2 instead of m s^-2, deg s^-1 for large rates).
_DISP = ChannelSpec("m", 1e-2, "displacement readout; 2.5x the 4 mm electrode gap D")
_ACC = ChannelSpec("m s^-2", 1e-4, "measured TM acceleration; 1000x F_max = 1e-7 m s^-2")
_FORCE = ChannelSpec("m s^-2", 1e-4, "commanded force per unit mass; 1000x F_max")
_REF = ChannelSpec("m", 1e-2, "reference motion; 2.5x the electrode gap")
_OMEGA = ChannelSpec("rad s^-1", 1e-2, "spacecraft angular rate (frame s); ~0.6 deg/s")
_OMEGA_DOT = ChannelSpec("rad s^-2", 1e-3, "spacecraft angular acceleration (frame s)")

CHANNEL_SPECS: dict[str, ChannelSpec] = {
    "time": ChannelSpec("s", math.inf, "sample time, uniform grid"),
    **{a: _DISP for a in AXES},
    **{f"acc_{a}": _ACC for a in AXES},
    **{f"force_{a}": _FORCE for a in AXES},
    "ref_x1": _REF,
    "ref_x2": _REF,
    **{f"sc_omega_{c}": _OMEGA for c in "xyz"},
    **{f"sc_omega_dot_{c}": _OMEGA_DOT for c in "xyz"},
}

_REQUIRED_ATTRS = ("format", "format_version", "sample_rate", "alpha", "phi1", "phi2")


@dataclass(frozen=True)
class Gap:
    """A run of masked samples ``[start, stop)`` and the channels that were NaN in it.

    ``inserted`` is True when the rows were missing from the file (a jump of the time
    grid) rather than stored as NaN.
    """

    start: int
    stop: int
    t_start: float
    t_end: float
    channels: tuple[str, ...]
    inserted: bool = False

    @property
    def n_samples(self) -> int:
        return self.stop - self.start


@dataclass
class Recording:
    """One recording: ``channels`` (name -> 1-D float64, all of length N) and ``attrs``.

    After :func:`validate` (which :func:`read_recording` always applies) ``valid`` (N,) is
    True where every channel is finite and ``gaps`` lists the masked runs; a recording
    built in memory has ``valid is None`` until validated.
    """

    channels: dict[str, np.ndarray]
    attrs: dict[str, Any]
    valid: np.ndarray | None = None
    gaps: list[Gap] = field(default_factory=list)
    source: str = "<memory>"

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(
                f"{self.source}: no channel {name!r}; has {sorted(self.channels)}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name in self.channels

    @property
    def n_samples(self) -> int:
        return int(self.channels["time"].size)

    @property
    def time(self) -> np.ndarray:
        return self.channels["time"]

    @property
    def sample_rate(self) -> float:
        return float(self.attrs["sample_rate"])

    @property
    def dt(self) -> float:
        return 1.0 / self.sample_rate

    @property
    def duration(self) -> float:
        """``N / sample_rate`` [s] (the span covered by N samples of a uniform grid)."""
        return self.n_samples / self.sample_rate

    @property
    def has_reference(self) -> bool:
        return "ref_x1" in self.channels

    @property
    def has_rotation(self) -> bool:
        """True when the spacecraft rate/acceleration witnesses are present."""
        return ROTATION_CHANNELS[0] in self.channels

    @property
    def description(self) -> str:
        return str(self.attrs.get("description", ""))

    def geometry(self, separation: float = 0.4) -> Geometry:
        """Nominal geometry from the attributes (``alpha`` is then ``phi2 - phi1``)."""
        return Geometry(float(self.attrs["phi1"]), float(self.attrs["phi2"]), separation)

    def segments(self, min_samples: int = 1) -> list[slice]:
        """Contiguous valid index ranges of at least ``min_samples`` samples."""
        valid = np.ones(self.n_samples, bool) if self.valid is None else self.valid
        edges = np.flatnonzero(np.diff(np.concatenate([[0], valid.astype(np.int8), [0]])))
        return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])
                if b - a >= min_samples]  # fmt: skip

    def copy(self) -> Recording:
        return Recording(
            {k: v.copy() for k, v in self.channels.items()}, dict(self.attrs),
            None if self.valid is None else self.valid.copy(), list(self.gaps), self.source,
        )


# --------------------------------------------------------------------------- validation


def validate(rec: Recording, source: str | None = None) -> Recording:
    """Check a recording against format version 1; return a validated copy.

    Raises :class:`RecordingError` naming ``source`` (default ``rec.source``) and the
    channel or attribute for: missing/unknown channels, an incomplete rotation group,
    wrong dtype or shape, unequal lengths, fewer than 2 samples, non-finite or
    non-increasing time, uneven sampling, a ``sample_rate`` that disagrees with the time
    steps, +-inf values, values outside :data:`CHANNEL_SPECS` bounds (wrong units), bad or
    missing attributes, and recordings with no valid sample.  Repairs: NaN samples are
    masked; rows missing from the grid are re-inserted as NaN and masked (see module doc).
    """
    src = rec.source if source is None else source
    attrs = _check_attrs(rec.attrs, src)
    channels = _check_channel_set(rec.channels, src)
    n = _check_shapes(channels, src)
    channels, inserted = _check_time(channels, attrs["sample_rate"], n, src)
    valid, gaps = _mask(channels, inserted, src)
    _check_ranges(channels, src)
    return Recording(channels, attrs, valid, gaps, src)


def _err(src: str, what: str) -> RecordingError:
    return RecordingError(f"{src}: {what}")


def _check_attrs(attrs: dict[str, Any], src: str) -> dict[str, Any]:
    missing = [a for a in _REQUIRED_ATTRS if a not in attrs]
    if missing:
        raise _err(src, f"missing attribute(s) {missing}; required {list(_REQUIRED_ATTRS)}")
    out = dict(attrs)
    if out["format"] != FORMAT:
        raise _err(src, f"attribute 'format' is {out['format']!r}, expected {FORMAT!r}")
    version = out["format_version"]
    if isinstance(version, bool) or not isinstance(version, (int, np.integer)):
        raise _err(src, f"attribute 'format_version' must be the integer {FORMAT_VERSION}; "
                        f"got {version!r}")  # fmt: skip
    if int(version) != FORMAT_VERSION:
        raise _err(src, f"attribute 'format_version' is {version}; this reader supports "
                        f"only {FORMAT_VERSION}")  # fmt: skip
    out["format_version"] = int(version)
    for name in ("sample_rate", "alpha", "phi1", "phi2"):
        out[name] = _float_attr(out[name], name, src)
    if not out["sample_rate"] > 0:
        raise _err(src, f"attribute 'sample_rate' must be in (0, inf) Hz; "
                        f"got {out['sample_rate']!r}")  # fmt: skip
    _check_angles(out, src)
    if "description" in out and not isinstance(out["description"], str):
        raise _err(src, f"attribute 'description' must be a string; got {out['description']!r}")
    return out


def _float_attr(value: Any, name: str, src: str) -> float:
    if isinstance(value, (bool, str, bytes)) or not isinstance(value, (int, float, np.number)):
        raise _err(src, f"attribute {name!r} must be a finite number; got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise _err(src, f"attribute {name!r} must be finite; got {value!r}")
    return value


def _check_angles(attrs: dict[str, Any], src: str) -> None:
    for name in ("alpha", "phi1", "phi2"):
        if abs(attrs[name]) > 2 * math.pi:
            raise _err(src, f"attribute {name!r} = {attrs[name]!r} is outside [-2pi, 2pi] "
                            "rad (degrees instead of radians?)")  # fmt: skip
    mismatch = abs(attrs["alpha"] - (attrs["phi2"] - attrs["phi1"]))
    if mismatch > ANGLE_TOLERANCE:
        raise _err(src, f"attribute 'alpha' = {attrs['alpha']!r} rad must equal phi2 - phi1 "
                        f"= {attrs['phi2'] - attrs['phi1']!r} rad (within {ANGLE_TOLERANCE} "
                        "rad)")  # fmt: skip
    if abs(math.sin(attrs["alpha"])) < 1e-6:
        raise _err(src, "attribute 'alpha' must not be a multiple of pi (coaxial layout: "
                        "no f_B-cancelling combination, Eq. 11)")  # fmt: skip


def _check_channel_set(channels: dict[str, Any], src: str) -> dict[str, np.ndarray]:
    missing = [c for c in REQUIRED_CHANNELS if c not in channels]
    if missing:
        raise _err(src, f"missing channel(s) {missing}; required {list(REQUIRED_CHANNELS)}")
    unknown = sorted(set(channels) - set(REQUIRED_CHANNELS) - set(OPTIONAL_CHANNELS))
    if unknown:
        raise _err(src, f"unknown channel(s) {unknown}; allowed are "
                        f"{list(REQUIRED_CHANNELS + OPTIONAL_CHANNELS)}")  # fmt: skip
    rot = [c for c in ROTATION_CHANNELS if c in channels]
    if rot and len(rot) != len(ROTATION_CHANNELS):
        absent = [c for c in ROTATION_CHANNELS if c not in channels]
        raise _err(src, f"rotation channel(s) {absent} missing: the spacecraft rate and "
                        f"acceleration channels come as a group of six ({rot} present)")
    if ("ref_x1" in channels) != ("ref_x2" in channels):
        raise _err(src, "channels 'ref_x1' and 'ref_x2' come as a pair; only one is present")
    out = {}
    for name in REQUIRED_CHANNELS + OPTIONAL_CHANNELS:
        if name in channels:
            out[name] = _as_float64(channels[name], name, src)
    return out


def _as_float64(value: Any, name: str, src: str) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind != "f" or arr.dtype.itemsize != 8:
        raise _err(src, f"channel {name!r} must be float64; got dtype {arr.dtype}")
    if arr.ndim != 1:
        raise _err(src, f"channel {name!r} must be 1-D; got shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def _check_shapes(channels: dict[str, np.ndarray], src: str) -> int:
    n = channels["time"].size
    for name, arr in channels.items():
        if arr.size != n:
            raise _err(src, f"channel {name!r} has {arr.size} samples, 'time' has {n} "
                            "(all channels must have one length)")  # fmt: skip
    if n < 2:
        raise _err(src, f"channel 'time' has {n} sample(s); at least 2 are needed")
    return n


def _check_time(
    channels: dict[str, np.ndarray], rate: float, n: int, src: str
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Check the grid; re-insert missing rows as NaN. Returns channels and an inserted mask."""
    t = channels["time"]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise _err(src, f"channel 'time' is not finite at sample {bad[0]} (time cannot be "
                        "masked; drop the row instead)")  # fmt: skip
    step = np.diff(t)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0])
        raise _err(src, f"channel 'time' is not strictly increasing at sample {k + 1} "
                        f"({float(t[k])!r} -> {float(t[k + 1])!r} s)")  # fmt: skip
    dt = 1.0 / rate
    base = float(np.median(step))
    if abs(base * rate - 1.0) > GRID_TOLERANCE:
        raise _err(src, f"attribute 'sample_rate' = {rate!r} Hz disagrees with channel 'time' "
                        f"(median step {base!r} s, i.e. {1 / base:.6g} Hz)")  # fmt: skip
    index = np.rint((t - t[0]) / dt)
    off = np.abs(t - t[0] - index * dt)
    if off.max() > GRID_TOLERANCE * dt:
        k = int(np.argmax(off))
        raise _err(src, f"channel 'time' is off the uniform grid t0 + n/sample_rate at sample "
                        f"{k} by {off[k]:.3g} s (> {GRID_TOLERANCE} dt): uneven sampling")
    if np.any(np.diff(index) == 0):
        raise _err(src, "channel 'time' has two samples on one grid point (uneven sampling)")
    total = int(index[-1]) + 1
    if total == n:
        return channels, np.zeros(n, bool)
    if total - n > n:
        raise _err(src, f"channel 'time' misses {total - n} of {total} grid samples (more than "
                        "half the record): refusing to repair")  # fmt: skip
    pos = index.astype(np.int64)
    out = {}
    for name, arr in channels.items():
        full = np.full(total, np.nan)
        full[pos] = arr
        out[name] = full
    out["time"] = t[0] + np.arange(total) / rate  # n / fs, as sample_times writes it
    out["time"][pos] = t  # keep stored stamps bit-exact where they exist
    inserted = np.ones(total, bool)
    inserted[pos] = False
    return out, inserted


def _mask(
    channels: dict[str, np.ndarray], inserted: np.ndarray, src: str
) -> tuple[np.ndarray, list[Gap]]:
    n = channels["time"].size
    nan = np.zeros(n, bool)
    for name, arr in channels.items():
        inf = np.flatnonzero(np.isinf(arr))
        if inf.size:
            t_bad = float(channels["time"][inf[0]])
            raise _err(src, f"channel {name!r} is infinite at sample {inf[0]} (t = {t_bad!r} "
                            "s); only NaN gaps are masked")
        nan |= np.isnan(arr)
    valid = ~nan
    if not valid.any():
        raise _err(src, "no valid sample: every sample has a NaN in some channel")
    gaps = []
    for seg in _runs(~valid):
        names = tuple(c for c, a in channels.items() if np.isnan(a[seg]).any())
        gaps.append(Gap(seg.start, seg.stop, float(channels["time"][seg.start]),
                        float(channels["time"][seg.stop - 1]), names,
                        bool(inserted[seg].all())))  # fmt: skip
    return valid, gaps


def _runs(mask: np.ndarray) -> list[slice]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def _check_ranges(channels: dict[str, np.ndarray], src: str) -> None:
    for name, arr in channels.items():
        spec = CHANNEL_SPECS[name]
        if not math.isfinite(spec.bound):
            continue
        peak = float(np.nanmax(np.abs(arr))) if np.isfinite(arr).any() else 0.0
        if peak > spec.bound:
            k = int(np.nanargmax(np.abs(arr)))
            raise _err(src, f"channel {name!r} reaches {arr[k]!r} {spec.unit} at sample {k}, "
                            f"outside the physical range |{name}| <= {spec.bound:g} "
                            f"{spec.unit} ({spec.meaning}); wrong units?")


# --------------------------------------------------------------------------- reading


def read_recording(path: str | Path) -> Recording:
    """Read and validate a recording: ``.h5``/``.hdf5``, or ``.csv`` with its ``.json`` sidecar.

    Raises :class:`RecordingError` naming the file (and channel/attribute) when the file
    is missing, truncated, corrupt or violates the format (see :func:`validate`).
    """
    path = Path(path)
    kind = _format_of(path)
    if not path.is_file():
        raise RecordingError(f"{path}: no such recording file")
    try:
        raw = _read_h5(path) if kind == "h5" else _read_csv(path)
    except RecordingError:
        raise
    except Exception as exc:  # noqa: BLE001 - corrupt bytes make h5py raise anything
        raise RecordingError(f"{path}: corrupt or unreadable recording "
                             f"({type(exc).__name__}: {exc})") from exc
    return validate(raw, str(path))


def recording_format(path: str | Path) -> Literal["h5", "csv"]:
    """The format a recording at ``path`` is written in, from its extension (check it
    before expensive work); :class:`RecordingError` names the allowed extensions."""
    return _format_of(Path(path))


def _format_of(path: Path, fmt: str | None = None) -> Literal["h5", "csv"]:
    suffix = path.suffix.lower()
    by_suffix = {".h5": "h5", ".hdf5": "h5", ".csv": "csv"}.get(suffix)
    if fmt is not None and fmt not in ("h5", "csv"):
        raise ValueError(f"fmt must be 'h5' or 'csv'; got {fmt!r}")
    if by_suffix is None:
        raise RecordingError(f"{path}: unknown recording extension {suffix!r}; use .h5, .hdf5 "
                             "or .csv")  # fmt: skip
    if fmt is not None and fmt != by_suffix:
        raise ValueError(f"fmt={fmt!r} contradicts the extension of {path}")
    return by_suffix  # type: ignore[return-value]


def _read_h5(path: Path) -> Recording:
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise RecordingError(f"{path}: not a readable HDF5 file (truncated or corrupt?): "
                             f"{exc}") from exc  # fmt: skip
    with h5:
        try:
            attrs = {k: _plain(v) for k, v in h5.attrs.items()}
        except OSError as exc:
            raise RecordingError(f"{path}: cannot read the root attributes: {exc}") from exc
        channels = {}
        for name, obj in h5.items():
            if not isinstance(obj, h5py.Dataset):
                raise RecordingError(f"{path}: {name!r} is a group, not a channel dataset")
            if obj.dtype.kind != "f" or obj.dtype.itemsize != 8:
                raise RecordingError(f"{path}: channel {name!r} must be float64; got dtype "
                                     f"{obj.dtype}")  # fmt: skip
            try:
                channels[name] = np.asarray(obj[()], dtype=np.float64)
            except (OSError, ValueError) as exc:
                raise RecordingError(f"{path}: channel {name!r} is unreadable (truncated or "
                                     f"corrupt file?): {exc}") from exc  # fmt: skip
    return Recording(channels, attrs, source=str(path))


def _plain(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def sidecar_path(path: str | Path) -> Path:
    """The JSON attribute sidecar of a CSV recording: same folder and stem, ``.json``."""
    return Path(path).with_suffix(".json")


def _read_csv(path: Path) -> Recording:
    side = sidecar_path(path)
    if not side.is_file():
        raise RecordingError(f"{path}: attribute sidecar {side} is missing")
    try:
        attrs = json.loads(side.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RecordingError(f"{side}: unreadable JSON attribute sidecar: {exc}") from exc
    if not isinstance(attrs, dict):
        raise RecordingError(f"{side}: the sidecar must hold a JSON object of attributes")
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{path}: unreadable CSV file: {exc}") from exc
    expected = attrs.pop(CSV_CHECKSUM, None)
    if expected is not None and hashlib.sha256(raw).hexdigest() != expected:
        raise RecordingError(f"{path}: the CSV does not match the checksum in {side.name} "
                             f"(corrupted or edited after writing; remove {CSV_CHECKSUM!r} "
                             "from the sidecar to accept an intentional edit)")
    names, data = _parse_csv(text, path)
    return Recording({c: data[:, j].copy() for j, c in enumerate(names)}, attrs,
                     source=str(path))  # fmt: skip


def _parse_csv(text: str, path: Path) -> tuple[list[str], np.ndarray]:
    lines = text.splitlines()
    if not lines:
        raise RecordingError(f"{path}: empty CSV file (no header)")
    names = [c.strip() for c in next(csv.reader([lines[0]]))]
    dup = sorted({c for c in names if names.count(c) > 1})
    if dup:
        raise RecordingError(f"{path}: duplicate column(s) {dup} in the header")
    try:  # fast path; on any failure the slow path below locates the bad cell
        data = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1, ndmin=2)
        if data.shape[1] == len(names) or data.size == 0:
            return names, data.reshape(-1, len(names))
    except ValueError:
        pass
    return names, _parse_rows(lines, names, path)


def _parse_rows(lines: list[str], names: list[str], path: Path) -> np.ndarray:
    """Row-by-row parse: empty cells and 'nan' are NaN; anything else non-numeric raises."""
    rows = []
    for lineno, row in enumerate(csv.reader(lines[1:]), start=2):
        if not row:
            continue
        if len(row) != len(names):
            raise RecordingError(f"{path}: line {lineno} has {len(row)} fields, the header "
                                 f"{len(names)}")  # fmt: skip
        vals = []
        for name, cell in zip(names, row):
            cell = cell.strip()
            try:
                vals.append(math.nan if cell == "" else float(cell))
            except ValueError:
                raise RecordingError(f"{path}: channel {name!r} at line {lineno} is not a "
                                     f"number: {cell!r}") from None  # fmt: skip
        rows.append(vals)
    return np.array(rows, dtype=np.float64).reshape(-1, len(names))


# --------------------------------------------------------------------------- writing


def write_recording(
    rec: Recording, path: str | Path, fmt: Literal["h5", "csv"] | None = None
) -> Path:
    """Validate ``rec`` and write it atomically (temporary file + rename); return the path.

    ``fmt`` defaults to the extension (``.h5``/``.hdf5`` -> HDF5, ``.csv`` -> CSV with a
    ``.json`` sidecar).  The CSV sidecar is renamed into place before the CSV itself, so a
    reader that finds the new CSV also finds its attributes.
    """
    path = Path(path)
    kind = _format_of(path, fmt)
    checked = validate(rec, str(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "h5":
        atomic_write(path, lambda tmp: _write_h5(checked, tmp))
    else:
        body = _csv_bytes(checked)
        meta = {**_json_attrs(checked.attrs), CSV_CHECKSUM: hashlib.sha256(body).hexdigest()}
        attrs = json.dumps(meta, indent=2, sort_keys=True)
        atomic_write(sidecar_path(path), lambda tmp: Path(tmp).write_text(attrs, encoding="utf-8"))
        atomic_write(path, lambda tmp: Path(tmp).write_bytes(body))
    return path


def _ordered(rec: Recording) -> list[str]:
    return [c for c in REQUIRED_CHANNELS + OPTIONAL_CHANNELS if c in rec.channels]


def _write_h5(rec: Recording, tmp: str) -> None:
    with h5py.File(tmp, "w") as h5:
        for key, value in rec.attrs.items():
            h5.attrs[key] = value
        for name in _ordered(rec):
            # Fletcher-32 checksums: a corrupted data byte is refused on read, not read as a
            # silently different number (files from other writers may lack them).
            h5.create_dataset(name, data=rec.channels[name], dtype="<f8", fletcher32=True)


def _csv_bytes(rec: Recording) -> bytes:
    names = _ordered(rec)
    data = np.column_stack([rec.channels[c] for c in names])
    buf = io.StringIO()
    # %.17g round-trips every float64 exactly; NaN is written as 'nan'
    np.savetxt(buf, data, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
    return buf.getvalue().encode("utf-8")


def _json_attrs(attrs: dict[str, Any]) -> dict[str, Any]:
    return {k: _plain(v) for k, v in attrs.items()}


# --------------------------------------------------------------------------- simulator


def recording_from_simulation(
    result: Any,
    i: int = 0,
    config: Any = None,
    description: str = "",
    geometry: Geometry | None = None,
) -> Recording:
    """Design ``i`` of a :class:`~tmopt.physics.simulator.SimulationResult` as a recording.

    Writes the measured channels (x, y readouts; acc; commanded force), the references
    and, when the simulation had spacecraft rotation, the six ``sc_omega*`` witnesses --
    never the true states nor the RLS estimates.  ``config`` defaults to
    ``result.config``; ``geometry`` (default ``config.geometry``) is the geometry written
    to the attributes, which a generator may set to the *nominal* one while the simulation
    ran with another (a concealed geometry error).  A diverged design raises ValueError.
    """
    config = result.config if config is None else config
    if result.channels is None:
        raise ValueError("result has no channels (config.record='estimates'); simulate with "
                         "record='full'")  # fmt: skip
    if not 0 <= i < result.batch_size:
        raise ValueError(f"i must be in [0, {result.batch_size - 1}]; got {i!r}")
    if result.diverged[i]:
        raise ValueError(f"design {i} diverged ({result.reason[i]}): not a recording")
    geo = config.geometry if geometry is None else geometry
    d = result.design(i)
    channels = {c: np.array(d[c], dtype=np.float64) for c in REQUIRED_CHANNELS}
    channels["ref_x1"] = np.array(d["ref_x1"], dtype=np.float64)
    channels["ref_x2"] = np.array(d["ref_x2"], dtype=np.float64)
    channels.update(_rotation_witnesses(result))
    attrs: dict[str, Any] = {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "sample_rate": float(config.sample_rate), "alpha": float(geo.alpha),
        "phi1": float(geo.phi1), "phi2": float(geo.phi2),
    }  # fmt: skip
    if description:
        attrs["description"] = description
    return validate(Recording(channels, attrs, source="<simulation>"))


def _rotation_witnesses(result: Any) -> dict[str, np.ndarray]:
    """``sc_omega*`` channels from the result's perturbations, when it had rotation."""
    pert = getattr(result, "perturbations", None)
    omega = None if pert is None else getattr(pert, "omega", None)
    if omega is None:
        return {}
    omega_dot = pert.omega_dot
    out = {f"sc_omega_{c}": np.array(omega[j], dtype=np.float64) for j, c in enumerate("xyz")}
    out.update({f"sc_omega_dot_{c}": np.array(omega_dot[j], dtype=np.float64)
                for j, c in enumerate("xyz")})  # fmt: skip
    return out
