"""Recording format v1: round trips, every validation error names its channel, repairs."""

import json
import math
import os

import h5py
import numpy as np
import pytest

import tmopt.physics.recording as recmod
from tmopt.physics.excitation import MultiSine
from tmopt.physics.recording import (
    CHANNEL_SPECS,
    FORMAT,
    OPTIONAL_CHANNELS,
    REQUIRED_CHANNELS,
    ROTATION_CHANNELS,
    Recording,
    RecordingError,
    read_recording,
    recording_from_simulation,
    sidecar_path,
    validate,
    write_recording,
)
from tmopt.physics.simulator import SimulationConfig, simulate

N = 200
FS = 10.0


def _recording(rotation: bool = True, n: int = N) -> Recording:
    rng = np.random.default_rng(3)
    t = np.arange(n) / FS
    ch = {"time": t}
    for name in REQUIRED_CHANNELS[1:] + OPTIONAL_CHANNELS:
        if name in ROTATION_CHANNELS and not rotation:
            continue
        # well inside each family's bound, random so a column swap would be noticed
        ch[name] = CHANNEL_SPECS[name].bound * 1e-3 * rng.standard_normal(n)
    attrs = {"format": FORMAT, "format_version": 1, "sample_rate": FS,
             "alpha": math.pi / 3, "phi1": math.pi / 3, "phi2": 2 * math.pi / 3,
             "description": "synthetic"}
    return Recording(ch, attrs)


def _assert_same(a: Recording, b: Recording) -> None:
    assert sorted(a.channels) == sorted(b.channels)
    for name in a.channels:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)  # bit-exact, NaN = NaN
    assert a.attrs == b.attrs


@pytest.mark.parametrize("ext", ["h5", "hdf5", "csv"])
def test_round_trip_is_bit_exact(tmp_path, ext):
    rec = _recording()
    rec.channels["acc_x1"][[5, 6]] = np.nan  # gaps survive the trip too
    path = write_recording(rec, tmp_path / f"r.{ext}")
    back = read_recording(path)
    _assert_same(rec, back)
    assert back.valid.sum() == N - 2 and back.source == str(path)
    if ext == "csv":
        assert json.loads(sidecar_path(path).read_text())["alpha"] == math.pi / 3
        assert path.read_text().splitlines()[0].split(",")[:2] == ["time", "x1"]


def test_optional_channels_may_be_absent(tmp_path):
    rec = _recording(rotation=False)
    del rec.channels["ref_x1"], rec.channels["ref_x2"]
    back = read_recording(write_recording(rec, tmp_path / "r.h5"))
    assert not back.has_rotation and not back.has_reference
    assert back.geometry().alpha == pytest.approx(math.pi / 3)


def test_fmt_must_agree_with_the_extension(tmp_path):
    with pytest.raises(ValueError, match="contradicts"):
        write_recording(_recording(), tmp_path / "r.h5", fmt="csv")
    with pytest.raises(RecordingError, match="extension"):
        write_recording(_recording(), tmp_path / "r.txt")


def _drop(name):
    def edit(rec):
        del rec.channels[name]
    return edit


def _set(name, value):
    def edit(rec):
        rec.channels[name] = value(rec.channels[name].copy())
    return edit


def _attr(name, value):
    def edit(rec):
        if value is None:
            del rec.attrs[name]
        else:
            rec.attrs[name] = value
    return edit


def _at(index, value):
    def f(a):
        a[index] = value
        return a
    return f


CORRUPTIONS = [
    (_drop("acc_y2"), "acc_y2"),
    (_drop("sc_omega_dot_z"), "sc_omega_dot_z"),
    (_drop("ref_x2"), "ref_x2"),
    (lambda r: r.channels.__setitem__("acc_X1", np.zeros(N)), "acc_X1"),
    (_set("force_x2", lambda a: a[:-1]), "force_x2"),
    (_set("x2", lambda a: a.astype(np.float32)), "x2"),
    (_set("y1", lambda a: np.stack([a, a])), "y1"),
    (_set("time", _at(7, np.nan)), "time"),
    (_set("time", _at(7, 0.55)), "time"),  # non-monotonic
    (_set("time", _at(7, 0.73)), "time"),  # uneven sampling
    (_set("acc_x1", _at(9, np.inf)), "acc_x1"),
    (_set("x1", lambda a: a * 1e3), "x1"),  # mm written as m
    (_set("acc_x2", lambda a: a * 1e9), "acc_x2"),  # nm s^-2 written as m s^-2
    (_set("force_y1", lambda a: a * 1e6), "force_y1"),
    (_set("ref_x1", lambda a: a * 1e6), "ref_x1"),
    (_set("sc_omega_z", lambda a: a * 1e3), "sc_omega_z"),
    (_set("sc_omega_dot_x", lambda a: a * 1e4), "sc_omega_dot_x"),
    (_attr("sample_rate", None), "sample_rate"),
    (_attr("sample_rate", 5.0), "sample_rate"),
    (_attr("sample_rate", -10.0), "sample_rate"),
    (_attr("sample_rate", 20.0), "sample_rate"),  # would otherwise look like gaps
    (_attr("phi1", 60.0), "phi1"),  # degrees
    (_attr("alpha", 1.2), "alpha"),  # not phi2 - phi1
    (_attr("format", "other"), "format"),
    (_attr("format_version", 2), "format_version"),
    (_attr("format_version", "1"), "format_version"),
    (_attr("description", 5), "description"),
]


@pytest.mark.parametrize("edit,name", CORRUPTIONS)
def test_every_validation_error_names_its_channel_or_attribute(edit, name):
    rec = _recording()
    edit(rec)
    with pytest.raises(RecordingError, match=f"'{name}'|{name}") as info:
        validate(rec, "file.h5")
    assert "file.h5" in str(info.value)


def test_time_cannot_have_fewer_than_two_samples():
    rec = _recording(n=1)
    with pytest.raises(RecordingError, match="'time' has 1 sample"):
        validate(rec)


def test_nan_gaps_are_masked_and_listed_not_filled():
    rec = _recording()
    rec.channels["acc_x1"][10:13] = np.nan
    rec.channels["x2"][12:15] = np.nan
    rec.channels["y1"][-1] = np.nan
    out = validate(rec)
    assert np.isnan(out["acc_x1"][10:13]).all()  # the NaN stays: ignoring the mask fails
    assert out.valid.sum() == N - 6
    assert [(g.start, g.stop, g.channels) for g in out.gaps] == [
        (10, 15, ("x2", "acc_x1")), (N - 1, N, ("y1",))]
    assert out.gaps[0].t_start == pytest.approx(1.0) and out.gaps[0].t_end == pytest.approx(1.4)
    assert out.segments() == [slice(0, 10), slice(15, N - 1)]
    assert out.segments(min_samples=11) == [slice(15, N - 1)]
    assert rec.valid is None  # validate returns a copy, the input is untouched


def test_rows_missing_from_the_grid_are_reinserted_as_masked_nan():
    rec = _recording()
    keep = np.r_[0:50, 53:N]
    rec.channels = {k: v[keep] for k, v in rec.channels.items()}
    out = validate(rec)
    assert out.n_samples == N and out.valid.sum() == N - 3
    np.testing.assert_array_equal(out.time, np.arange(N) / FS)
    assert out.gaps[0].start == 50 and out.gaps[0].stop == 53 and out.gaps[0].inserted
    assert set(out.gaps[0].channels) == set(out.channels) - {"time"}


def test_a_recording_that_is_mostly_missing_is_refused():
    rec = _recording()
    keep = np.r_[0:20, 150:N]
    rec.channels = {k: v[keep] for k, v in rec.channels.items()}
    rec.channels["time"][20:] += 100.0  # 1000 missing rows after row 20
    with pytest.raises(RecordingError, match="more than half"):
        validate(rec)


def test_all_nan_is_an_error():
    rec = _recording()
    rec.channels["x1"][:] = np.nan
    with pytest.raises(RecordingError, match="no valid sample"):
        validate(rec)


def test_truncated_or_corrupt_hdf5_names_the_file(tmp_path):
    path = write_recording(_recording(), tmp_path / "r.h5")
    data = path.read_bytes()
    bad = tmp_path / "truncated.h5"
    bad.write_bytes(data[: len(data) // 3])
    with pytest.raises(RecordingError, match="truncated.h5"):
        read_recording(bad)
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not an hdf5 file at all" * 10)
    with pytest.raises(RecordingError, match="junk.h5"):
        read_recording(junk)
    with pytest.raises(RecordingError, match="no such recording"):
        read_recording(tmp_path / "absent.h5")


def test_hdf5_wrong_dtype_group_and_missing_attribute(tmp_path):
    path = write_recording(_recording(), tmp_path / "r.h5")
    with h5py.File(path, "a") as h5:
        data = h5["acc_y1"][()]
        del h5["acc_y1"]
        h5.create_dataset("acc_y1", data=data.astype(np.float32))
    with pytest.raises(RecordingError, match="r.h5.*'acc_y1'.*float64"):
        read_recording(path)
    path = write_recording(_recording(), tmp_path / "g.h5")
    with h5py.File(path, "a") as h5:
        h5.create_group("extra")
    with pytest.raises(RecordingError, match="'extra' is a group"):
        read_recording(path)
    path = write_recording(_recording(), tmp_path / "a.h5")
    with h5py.File(path, "a") as h5:
        del h5.attrs["phi2"]
    with pytest.raises(RecordingError, match="a.h5.*phi2"):
        read_recording(path)


def _as_from_another_writer(path):
    """Drop tmopt's CSV checksum, as a CSV written by another tool would not have one."""
    side = sidecar_path(path)
    attrs = json.loads(side.read_text())
    attrs.pop("csv_sha256")
    side.write_text(json.dumps(attrs))


def test_csv_errors_name_file_channel_and_line(tmp_path):
    path = write_recording(_recording(rotation=False), tmp_path / "r.csv")
    _as_from_another_writer(path)
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[4].split(",")
    row[header.index("force_x2")] = "oops"
    path.write_text("\n".join(lines[:4] + [",".join(row)] + lines[5:]) + "\n")
    with pytest.raises(RecordingError, match="'force_x2' at line 5"):
        read_recording(path)
    path.write_text("\n".join(lines[:4] + [",".join(row[:-1])] + lines[5:]) + "\n")
    with pytest.raises(RecordingError, match="line 5 has"):
        read_recording(path)
    sidecar_path(path).unlink()
    with pytest.raises(RecordingError, match="sidecar"):
        read_recording(path)


def test_empty_csv_cells_are_nan_gaps(tmp_path):
    path = write_recording(_recording(rotation=False), tmp_path / "r.csv")
    _as_from_another_writer(path)
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[8].split(",")
    row[header.index("y2")] = ""
    path.write_text("\n".join(lines[:8] + [",".join(row)] + lines[9:]) + "\n")
    back = read_recording(path)
    assert back.gaps[0].start == 7 and back.gaps[0].channels == ("y2",)


def test_corrupted_data_bytes_are_refused_not_read_as_other_numbers(tmp_path):
    rec = _recording(rotation=False)
    csv_path = write_recording(rec, tmp_path / "r.csv")
    text = csv_path.read_text()
    digit = text.index("e-", len(text) // 2) - 1  # a mantissa digit of some value
    flipped = "1" if text[digit] != "1" else "2"
    csv_path.write_text(text[:digit] + flipped + text[digit + 1:])
    with pytest.raises(RecordingError, match="does not match the checksum"):
        read_recording(csv_path)
    h5_path = write_recording(rec, tmp_path / "r.h5")
    with h5py.File(h5_path, "r") as h5:  # where x1's bytes are in the file
        offset = h5["x1"].id.get_chunk_info(0).byte_offset
    data = bytearray(h5_path.read_bytes())
    data[offset + 100] ^= 0xFF
    h5_path.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match="x1"):
        read_recording(h5_path)


def test_writer_killed_midway_leaves_the_previous_file(tmp_path, monkeypatch):
    path = write_recording(_recording(), tmp_path / "r.h5")
    before = path.read_bytes()

    def boom(rec, tmp):
        with open(tmp, "wb") as fh:
            fh.write(b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(recmod, "_write_h5", boom)
    with pytest.raises(KeyboardInterrupt):
        write_recording(_recording(), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["r.h5"]  # no temporary left behind


def test_invalid_recordings_are_not_written(tmp_path):
    rec = _recording()
    rec.channels["x1"] = rec.channels["x1"] * 1e3
    with pytest.raises(RecordingError, match="'x1'"):
        write_recording(rec, tmp_path / "r.h5")
    assert not os.listdir(tmp_path)


def test_recording_from_simulation_keeps_only_measured_channels(tmp_path):
    cfg = SimulationConfig(duration=20.0)
    res = simulate(MultiSine(5e-5, 2 * math.pi / 300), MultiSine(3e-5, 2 * math.pi / 500),
                   cfg, seed=4)
    rec = recording_from_simulation(res, 0, description="unit test")
    assert set(rec.channels) == set(REQUIRED_CHANNELS) | {"ref_x1", "ref_x2"}
    for name in REQUIRED_CHANNELS[1:]:
        np.testing.assert_array_equal(rec[name], getattr(res, name)[0])
    np.testing.assert_array_equal(rec["ref_x1"], res.ref_x1[0])
    assert rec.attrs["phi1"] == cfg.geometry.phi1 and rec.attrs["sample_rate"] == 10.0
    assert rec.description == "unit test" and rec.valid.all()
    back = read_recording(write_recording(rec, tmp_path / "sim.h5"))
    _assert_same(rec, back)


def test_recording_from_a_diverged_design_is_refused():
    cfg = SimulationConfig(stiffness_1=(1e-2, 1e-7), duration=300.0)
    res = simulate(MultiSine(1e-4, 2 * math.pi / 300), MultiSine(1e-5, 2 * math.pi / 300), cfg)
    with pytest.raises(ValueError, match="diverged"):
        recording_from_simulation(res, 0)
