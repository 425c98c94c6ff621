"""experiments/mismatch_conventions.py's ``pinned``, ``likelihood`` (docs/mismatch.md
9.31), ``null``, ``scan`` and ``survey --setting`` (9.32): bad input is refused in one
line naming the parameter, before any recording is made; ``null-summary``'s counts."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture
def mc(monkeypatch):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions

    return mismatch_conventions


def _refused(mc, monkeypatch, argv: list[str], match: str) -> None:
    """``main(argv)`` exits with one line matching ``match`` before its subcommand's work."""

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mc, argv[0].replace("-", "_"), never)
    with pytest.raises(SystemExit, match=match) as exc:
        mc.main(argv)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize(("args", "named"), [
    (["--records", "foreign:12"], "--records"),
    (["--records", "satellite:300014"], "--records"),
    (["--records", "foreign:300014", "--pin", "chosen,middle"], "--pin"),
])  # fmt: skip
def test_pinned_refuses_bad_input_before_any_work(mc, monkeypatch, tmp_path, args, named):
    _refused(mc, monkeypatch, ["pinned", *args, "--out", str(tmp_path / "rows.jsonl")], named)
    assert not (tmp_path / "rows.jsonl").exists()


def test_likelihood_refuses_a_bad_record_before_any_work(mc, monkeypatch):
    _refused(mc, monkeypatch, ["likelihood", "--records", "foreign:300014,kernel:300014x"],
             "--records: 'kernel:300014x' is not SEED")  # fmt: skip


def test_records_are_read_as_the_benchmarks_only(mc):
    """One parser for recording lists (``mismatch_realistic.parse_records``, on
    ``parse_only``): a bare seed names both simulators."""
    assert mc._records("300014, kernel:300001") == [
        ("foreign", 300014), ("kernel", 300001), ("kernel", 300014)]


@pytest.mark.parametrize(("args", "named"), [
    (["--seeds", "300000-300010"], "--seeds"),
    (["--seeds", "37400-37401", "--backends", "kernel,satellite"], "--backends"),
])  # fmt: skip
def test_null_refuses_bad_input_before_any_work(mc, monkeypatch, tmp_path, args, named):
    _refused(mc, monkeypatch, ["null", *args, "--out", str(tmp_path / "rows.jsonl")], named)


def test_survey_refuses_a_bad_setting_before_any_work(mc, monkeypatch, tmp_path):
    _refused(mc, monkeypatch, ["survey", "--seeds", "37400-37400", "--setting",
                               "convention_profile=maybe", "--out", str(tmp_path / "r.jsonl")],
             "--setting: convention_profile must be true or false")  # fmt: skip


def test_scan_refuses_an_unread_set_before_any_work(mc, monkeypatch):
    """``scan`` reads read sets only (130000-300000): a never-seen draw is not spent."""
    _refused(mc, monkeypatch, ["scan", "--seed-base", "310000", "--out", "rows.jsonl"],
             "--seed-base must be a read benchmark set")  # fmt: skip


def _row(recorded, chosen, behind):
    return {"backend": "foreign", "seed": 1, "recorded": recorded, "chosen": chosen,
            "left": sorted(behind), "behind": behind}


def test_null_summary_counts_the_rule_at_each_lead(mc, tmp_path):
    """The rule's pick (``rule_pick``) takes the profile's best only where it leads every
    other by the lead; elsewhere the read before the rule stands."""
    rows = [_row("mean", "held", {"held": 5.0, "mean": 0.0, "end": 12.0}),  # fixed at 3.84
            _row("end", "held", {"held": 2.0, "mean": 1.0, "end": 0.0}),  # too close: kept
            _row("held", "held", {"held": 0.0, "mean": 20.0}),  # decided, right
            _row("held", "held", {})]  # the equation group decided
    assert [mc.rule_pick(r, 3.84) for r in rows] == ["mean", "held", "held", "held"]
    assert [mc.rule_pick(r, 6.63) for r in rows] == ["held", "held", "held", "held"]
    path = tmp_path / "null.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    table = mc.null_summary([str(path)], leads=(3.84, 6.63))
    # all rows: 4 records, 3 undecided by Eq. 10, 2 read wrong before the rule; at 3.84
    # 1 wrong of 2 decided, at 6.63 2 wrong of 1 decided
    assert "| all | all | 4 | 3 | 2 | 1 / 2 | 2 / 1 |" in table


def test_rows_out_keeps_what_is_done(mc, tmp_path):
    """The resume keys of an ``--out`` (its folder made when new)."""
    path = tmp_path / "new" / "rows.jsonl"
    out, done = mc._rows_out(str(path), lambda r: r["seed"])
    assert out == path and done == set() and path.parent.is_dir()
    path.write_text('{"seed": 3}\n{"seed": 5}\n')
    assert mc._rows_out(str(path), lambda r: r["seed"])[1] == {3, 5}
