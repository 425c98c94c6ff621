"""Nonsense in, no physics out (issue 20, part 4).

A generator of mutated recordings -- white noise, constant and all-zero channels, shuffled
samples, swapped channels, unit errors, truncations, readouts running backwards, a wrong
sample rate, stuck sensors, mostly-missing data -- each with random parameters, applied to clean
recordings of both simulators.  For every one of them the tool must refuse ("cannot
diagnose: <why>"), or at most report an *unexplained* mismatch; it must never name a
catalogue effect, never answer "no significant mismatch", and never raise.  The counts
are printed (docs/robustness.md, "Mismatch tool: nonsense recordings").
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from tmopt.mismatch.diagnose import diagnose
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generate import generate_recording
from tmopt.mismatch.realistic import draw_scenario, realistic_recording
from tmopt.mismatch.report import build_report
from tmopt.physics.recording import AXES, Recording, RecordingError, validate

MEASURED = [*AXES, *(f"acc_{a}" for a in AXES), *(f"force_{a}" for a in AXES)]


@pytest.fixture(scope="module")
def bases() -> list[Recording]:
    """Clean recordings: the paper's settings (short) and two flight-like ones."""
    out = [generate_recording((), seed=1, duration=600.0, sample_rate=2.0)[0]]
    for seed, backend in ((3, "kernel"), (4, "foreign")):
        sc = replace(draw_scenario(seed, backend), duration=1200.0, sample_rate=2.0, gaps=())
        out.append(realistic_recording(sc, seed=seed, backend=backend)[0])
    return out


def _with(rec: Recording, chans: dict, attrs: dict | None = None) -> Recording:
    out = {k: np.array(v, dtype=float) for k, v in rec.channels.items()}
    out.update(chans)
    return Recording(out, {**rec.attrs, **(attrs or {})}, source="<mutated>")


def _white(rec, rng):
    return _with(rec, {c: rng.standard_normal(rec.n_samples) * float(np.std(rec[c]) or 1e-9)
                       for c in MEASURED})  # fmt: skip


def _constant(rec, rng):
    c = str(rng.choice(MEASURED))
    return _with(rec, {c: np.full(rec.n_samples, float(rng.choice([0.0, np.mean(rec[c])])))})


def _zero(rec, rng):
    return _with(rec, {c: np.zeros(rec.n_samples) for c in rec.channels if c != "time"})


def _shuffled(rec, rng):
    perm = rng.permutation(rec.n_samples)
    return _with(rec, {c: rec[c][perm] for c in rec.channels if c != "time"})


def _shuffled_one(rec, rng):
    c = str(rng.choice(MEASURED[:2] + MEASURED[4:6] + MEASURED[8:10]))
    return _with(rec, {c: rec[c][rng.permutation(rec.n_samples)]})


def _swap(rec, rng):
    pairs = [("x1", "x2"), ("acc_x1", "acc_x2"), ("force_x1", "force_x2"), ("x1", "y1"),
             ("acc_x1", "x1"), ("force_x2", "x2"), ("acc_x2", "acc_y2")]  # fmt: skip
    a, b = pairs[int(rng.integers(len(pairs)))]
    return _with(rec, {a: rec[b], b: rec[a]})


def _units(rec, rng):
    c = str(rng.choice(MEASURED[:2] + MEASURED[4:6] + MEASURED[8:10]))
    factor = float(rng.choice([1e3, 1e-3, 1e6, -1.0]))
    v = rec[c] * factor
    bound = 1e-2 if c in AXES else 1e-4
    return _with(rec, {c: np.clip(v, -bound, bound)})


def _truncated(rec, rng):
    n = int(rng.choice([2, 3, 17, 20, 64, 200]))
    return Recording({c: v[:n].copy() for c, v in rec.channels.items()}, dict(rec.attrs),
                     source="<mutated>")  # fmt: skip


def _reversed(rec, rng):
    """The readouts (or the accelerometers) run backwards, the other channels forwards.
    (Reversing *every* channel is no nonsense to this tool: the plant of Eq. 10 has no
    damping, so a reversed record is a valid record of the same plant under the reversed
    force, and a linear Gaussian loop is statistically time-reversible.)"""
    group = AXES if rng.random() < 0.5 else tuple(f"acc_{a}" for a in AXES)
    return _with(rec, {c: rec[c][::-1] for c in group})


def _rate(rec, rng):
    factor = float(rng.choice([0.25, 0.5, 2.0, 4.0]))
    fs = rec.sample_rate * factor
    return _with(rec, {"time": np.arange(rec.n_samples) / fs}, {"sample_rate": fs})


def _stuck(rec, rng):
    c = str(rng.choice(MEASURED[:2] + MEASURED[4:6]))
    v = rec[c].copy()
    a = int(rng.integers(0, rec.n_samples // 4))
    v[a:] = v[a]
    return _with(rec, {c: v})


def _mostly_missing(rec, rng):
    keep = np.zeros(rec.n_samples, bool)
    for _ in range(int(rng.integers(1, 6))):
        a = int(rng.integers(0, rec.n_samples - 60))
        keep[a : a + int(rng.integers(10, 60))] = True
    chans = {c: np.where(keep, rec[c], np.nan) for c in rec.channels if c != "time"}
    return _with(rec, chans)


#: Mutation -> maker.  Every one is nonsense as a closed-loop recording of this instrument.
MUTATIONS = {
    "white noise": _white, "constant channel": _constant, "all zero": _zero,
    "shuffled samples": _shuffled, "one channel shuffled": _shuffled_one,
    "swapped channels": _swap, "unit error or sign flip": _units, "truncated": _truncated,
    "half time-reversed": _reversed, "wrong sample rate": _rate, "stuck sensor": _stuck,
    "mostly missing": _mostly_missing,
}  # fmt: skip
#: Recordings per mutation: the default suite (12 kinds x 3 = 36, every kind once on each
#: of the three bases; 72 until stop 59, CI time) and the full sweep that
#: docs/robustness.md counts (`make test-slow`: 216).  The full sweep cost 43 s, then
#: ~120 s once names beyond physics were taken out and the selection rerun (issue 26): a
#: long study, so `slow`.
PER_KIND = 3
PER_KIND_FULL = 18


def outcome(rec: Recording) -> tuple[str, str]:
    """(kind, detail): 'refused' (a clear message), 'unexplained' (no name), 'named',
    'no mismatch' or 'traceback'."""
    try:
        rec = validate(rec)
    except RecordingError as exc:
        return "refused", f"format: {exc}"
    try:
        rep = build_report(diagnose(data_from_recording(rec)))
    except Exception as exc:  # noqa: BLE001 - what this test counts
        return "traceback", f"{type(exc).__name__}: {exc}"
    if rep["status"] == "cannot_diagnose":
        return "refused", rep["reason"]
    if rep["effects"]:
        return "named", rep["conclusion"]
    if not rep["mismatch_detected"]:
        return "no mismatch", rep["conclusion"]
    return "unexplained", rep["conclusion"]


def sweep(bases: list[Recording], per_kind: int) -> tuple[dict[str, Counter], list]:
    """Every mutation ``per_kind`` times (random parameters, both simulators' bases):
    outcome counts per kind and the cases that were neither refused nor unexplained."""
    rng = np.random.default_rng(20)
    results: dict[str, Counter] = {}
    bad = []
    for kind, make in MUTATIONS.items():
        for i in range(per_kind):
            base = bases[i % len(bases)]
            got, detail = outcome(make(base, rng))
            results.setdefault(kind, Counter())[got] += 1
            if got not in ("refused", "unexplained"):
                bad.append((kind, got, detail[:200]))
    total = sum(sum(c.values()) for c in results.values())
    print(f"\n{total} mutated recordings")
    for kind, c in results.items():
        print(f"  {kind:24s} {dict(c)}")
    for b in bad:
        print("  NOT REFUSED:", *b)
    return results, bad


@pytest.fixture(scope="module")
def nonsense(bases) -> tuple[dict[str, Counter], list[tuple[str, str, str]]]:
    return sweep(bases, PER_KIND)


def _counted_every_kind(results: dict[str, Counter], per_kind: int) -> None:
    assert {k: sum(c.values()) for k, c in results.items()} == \
        {k: per_kind for k in MUTATIONS}  # fmt: skip


def _no_crash_nor_consistent(bad: list) -> None:
    assert not [b for b in bad if b[1] == "traceback"], bad
    assert not [b for b in bad if b[1] == "no mismatch"], bad


def _no_catalogue_name(bad: list) -> None:
    assert not [b for b in bad if b[1] == "named"], bad


def test_nonsense_recordings_never_crash_nor_pass_as_consistent(nonsense):
    results, bad = nonsense
    _counted_every_kind(results, PER_KIND)
    _no_crash_nor_consistent(bad)


def test_nonsense_recordings_get_no_catalogue_name(nonsense):
    _no_catalogue_name(nonsense[1])


@pytest.mark.slow
def test_the_full_nonsense_sweep(bases):
    """The 216 recordings docs/robustness.md counts (``-s`` prints them)."""
    results, bad = sweep(bases, PER_KIND_FULL)
    _counted_every_kind(results, PER_KIND_FULL)
    _no_crash_nor_consistent(bad)
    _no_catalogue_name(bad)


def test_the_base_recordings_are_diagnosed_not_refused(bases):
    for rec in bases:
        got, detail = outcome(rec)
        assert got in ("no mismatch", "unexplained"), detail


@pytest.mark.parametrize("n", [2, 17, 20])
def test_short_recordings_say_why(bases, n):
    rec = Recording({c: v[:n].copy() for c, v in bases[0].channels.items()},
                    dict(bases[0].attrs))  # fmt: skip
    got, detail = outcome(rec)
    assert got == "refused" and "samples" in detail, detail


def test_an_all_zero_recording_is_refused_naming_a_channel(bases):
    got, detail = outcome(_zero(bases[0], None))
    assert got == "refused" and "constant channel" in detail, detail


def test_each_axis_force_follows_its_own_readout(bases):
    """The per-axis loop check (issue 20.4's last two named cases): on the clean bases of
    both simulators every axis's force follows its own readout; a shuffled readout breaks
    its axis's loop, and swapped readouts are followed by the other axis's force."""
    from tmopt.mismatch.plausibility import check_axis_loops

    rng = np.random.default_rng(7)
    for rec in bases:
        assert check_axis_loops(data_from_recording(validate(rec))).status == "ok"
        perm = rng.permutation(rec.n_samples)
        shuffled = check_axis_loops(data_from_recording(validate(
            _with(rec, {"x1": rec["x1"][perm]}))))  # fmt: skip
        assert shuffled.status == "fail" and "force on x1" in shuffled.detail, shuffled.detail
        swapped = check_axis_loops(data_from_recording(validate(
            _with(rec, {"x1": rec["y1"], "y1": rec["x1"]}))))  # fmt: skip
        assert swapped.status == "fail", swapped.detail
        assert "force on x1 follows the" in swapped.detail and "y1" in swapped.detail, \
            swapped.detail  # fmt: skip


def test_a_rail_is_found_only_where_a_clip_piles_samples_on_one_value():
    """An ADC at its rail holds many samples at exactly its extreme value; a continuous
    reading never repeats one, and a uniformly quantised one holds fewest samples in its
    outermost codes (docs/mismatch.md 9.10)."""
    from tmopt.mismatch.plausibility import rail_mask

    rng = np.random.default_rng(7)
    v = rng.standard_normal(20000)
    assert rail_mask(v)[1] == []
    assert rail_mask(np.round(v / 0.05) * 0.05)[1] == []  # a fine quantiser: tails thin
    assert rail_mask(np.round(v))[1] == []  # a coarse one (5 codes each side): still thin
    level = float(np.quantile(np.abs(v), 0.9))
    mask, levels = rail_mask(np.clip(v, -level, level))
    assert levels == [-level, level]
    assert mask.sum() == np.sum(np.abs(v) >= level)
    mask, levels = rail_mask(np.minimum(v, level))  # one rail only
    assert levels == [level] and mask.sum() == np.sum(v >= level)


def test_a_clipped_accelerometer_is_unexplained_at_its_axis_not_refused_as_swapped():
    """The benchmark's foreign recording 50135 (a set already read, r7), acc_x1 clipped
    at its 90 % quantile while the commands reach 11x that level: over all samples the
    slope of acc on force was 0.25 and the recording was refused as 'unrelated, swapped
    or rescaled channels' (at bcb5c72).  Without the rail samples the relation holds; the
    saturation is reported at x1.  (Development seeds 517/518 clip less deeply: they
    passed the check before too.)"""
    from tmopt.mismatch.plausibility import check_force_acc, check_saturation
    from tmopt.mismatch.realistic import OUT_OF_CATALOGUE, make_ooc

    assert "acc_clipping" in OUT_OF_CATALOGUE
    seed, backend = 50135, "foreign"
    sc = draw_scenario(seed, backend)
    rec, _ = realistic_recording(sc, [], [make_ooc("acc_clipping", 0.9, "x1", seed, sc)],
                                 seed, backend)  # fmt: skip
    data = data_from_recording(rec)
    sat = check_saturation(data)
    assert sat.status == "unknown"
    assert [s["channel"] for s in sat.values["saturated"]] == ["acc_x1"], sat.detail
    assert check_force_acc(data).status != "fail"


def test_dropped_samples_become_gaps_and_short_pieces_go_with_them():
    """``fit.drop_samples`` (the rail mask's, docs/mismatch.md 9.22): the segments split at
    each dropped sample, a piece shorter than MIN_SEGMENT between two drops is left out
    too, a gap already there stays one, and usage counts what is left out."""
    import math

    from tmopt.mismatch.fit import MIN_SEGMENT, Data, drop_samples
    from tmopt.physics.geometry import Geometry

    n, fs = 1000, 4.0
    t = np.arange(n + 100) / fs
    t = np.delete(t, np.arange(500, 600))  # a gap already there: samples 0-499, 500-999
    rng = np.random.default_rng(1)
    data = Data(time=t, fs=fs, x=rng.standard_normal((4, n)), acc=rng.standard_normal((4, n)),
                force=rng.standard_normal((4, n)),
                geometry=Geometry(math.radians(60), math.radians(120)),
                segments=[(0, 500), (500, n)], usage={"samples_recorded": n + 100})  # fmt: skip
    drop = np.zeros(n, bool)
    drop[[200, 200 + MIN_SEGMENT // 2, 700]] = True  # a short piece between the first two
    out = drop_samples(data, drop, "test")
    assert out.segments == [(0, 200), (200, 467), (467, 667), (667, 966)]
    keep = np.r_[0:200, 233:500, 500:700, 701:n]  # 201-232: shorter than MIN_SEGMENT
    assert np.array_equal(out.time, t[keep])
    assert np.array_equal(out.x, data.x[:, keep]) and np.array_equal(out.force,
                                                                     data.force[:, keep])
    assert out.usage["samples_used"] == 966 and out.usage["samples_left_out"] == n - 966
    assert out.usage["segments_dropped"] == 1 and out.usage["segments_used"] == 4
    assert "3 samples left out as gaps (test)" in out.notes[-1]
    with pytest.raises(ValueError, match="drop must have shape"):
        drop_samples(data, drop[:-1], "test")


def test_a_record_cut_into_short_pieces_is_flagged_not_refused(monkeypatch):
    """Many short gap-free segments (median below FRAGMENT_SAMPLES) make the noise model's
    low frequencies unreliable (docs/mismatch.md 9.22): the check says so, the diagnosis
    runs, and the report carries the caution as a note.  The same recording uncut is ok."""
    from pathlib import Path

    from tmopt.mismatch.plausibility import FRAGMENT_SAMPLES, check_fragmentation

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[2] / "experiments"))
    from mismatch_gap_calibration import random_gaps

    seed, backend = 611, "kernel"
    sc = draw_scenario(seed, backend)
    whole = data_from_recording(realistic_recording(replace(sc, gaps=()), (), (), seed,
                                                    backend)[0])  # fmt: skip
    assert check_fragmentation(whole).status == "ok"
    cut = data_from_recording(realistic_recording(
        replace(sc, gaps=random_gaps(48, sc.duration, seed)), (), (), seed, backend)[0])
    check = check_fragmentation(cut)
    assert check.status == "unknown", check.detail
    assert check.values["segments"] >= 2 and check.values["median_samples"] < FRAGMENT_SAMPLES
    rep = build_report(diagnose(cut))
    assert rep["status"] == "diagnosed", rep.get("reason")
    assert [c["status"] for c in rep["checks"] if c["name"] == "fragmentation"] == ["unknown"]
    assert any(n.startswith("caution: the record is cut into") for n in rep["notes"])


@pytest.mark.slow  # one 70 s diagnosis; the default sweep's unit errors and sign flips stay
def test_a_sign_flipped_force_on_the_foreign_base_is_refused_not_raised(bases):
    """The full sweep's one traceback (stop 52: LinAlgError in the noise model's spline
    fit, see test_noise_model's wide-spectrum test): no traceback and no name.  Which of
    the sweep's two honest outcomes it reaches depends on the machine's floating point
    (stop 58: the same code refused it on the machines before and reports it unexplained
    on an AMD EPYC, where only two explanations beyond physics precede the third that
    refuses): refused, naming the parameter beyond its physical range, or unexplained,
    with the negative gain on x1 said to be beyond physics."""
    rec = bases[2]
    got, detail = outcome(_with(rec, {"force_x1": -rec["force_x1"]}))
    if got == "refused":
        assert "beyond its physical range" in detail, detail
    else:
        assert got == "unexplained", detail
        assert "explanation beyond physics taken out (actuation_gain[x1])" in detail, detail
