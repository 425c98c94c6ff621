"""experiments/mismatch_conventions.py's ``pinned``, ``likelihood`` (docs/mismatch.md
9.31), ``null`` and ``survey --setting`` (9.32): bad input is refused in one line naming
the parameter, before any recording is made; ``null-summary``'s counts."""

from __future__ import annotations

from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@pytest.mark.parametrize(("args", "named"), [
    (["--records", "foreign:12"], "--records"),
    (["--records", "satellite:300014"], "--records"),
    (["--records", "foreign:300014", "--pin", "chosen,middle"], "--pin"),
])  # fmt: skip
def test_pinned_refuses_bad_input_before_any_work(monkeypatch, tmp_path, args, named):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions as mc

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mc, "pinned", never)
    with pytest.raises(SystemExit, match=named) as exc:
        mc.main(["pinned", *args, "--out", str(tmp_path / "rows.jsonl")])
    assert "\n" not in str(exc.value)
    assert not (tmp_path / "rows.jsonl").exists()


def test_likelihood_refuses_a_bad_record_before_any_work(monkeypatch):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions as mc

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mc, "likelihood", never)
    with pytest.raises(SystemExit, match="--records: 'kernel:300014x' is not SEED"):
        mc.main(["likelihood", "--records", "foreign:300014,kernel:300014x"])


def test_records_are_read_as_the_benchmarks_only(monkeypatch):
    """One parser for recording lists (``parse_only``): a bare seed names both simulators."""
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions as mc

    assert mc._records("300014, kernel:300001") == [
        ("foreign", 300014), ("kernel", 300001), ("kernel", 300014)]


@pytest.mark.parametrize(("args", "named"), [
    (["--seeds", "300000-300010"], "--seeds"),
    (["--seeds", "37400-37401", "--backends", "kernel,satellite"], "--backends"),
])  # fmt: skip
def test_null_refuses_bad_input_before_any_work(monkeypatch, tmp_path, args, named):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions as mc

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mc, "null", never)
    with pytest.raises(SystemExit, match=named) as exc:
        mc.main(["null", *args, "--out", str(tmp_path / "rows.jsonl")])
    assert "\n" not in str(exc.value)


def test_survey_refuses_a_bad_setting_before_any_work(monkeypatch, tmp_path):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions as mc

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mc, "survey", never)
    with pytest.raises(SystemExit, match="--setting: convention_profile must be true or false"):
        mc.main(["survey", "--seeds", "37400-37400", "--setting", "convention_profile=maybe",
                 "--out", str(tmp_path / "rows.jsonl")])  # fmt: skip


def _row(recorded, chosen, behind):
    return {"backend": "foreign", "seed": 1, "recorded": recorded, "chosen": chosen,
            "left": sorted(behind), "behind": behind}


def test_null_summary_counts_the_rule_at_each_lead(monkeypatch, tmp_path):
    """The rule's pick (``rule_pick``) takes the profile's best only where it leads every
    other by the lead; elsewhere the shipped choice stands."""
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import json

    import mismatch_conventions as mc

    rows = [_row("mean", "held", {"held": 5.0, "mean": 0.0, "end": 12.0}),  # fixed at 3.84
            _row("end", "held", {"held": 2.0, "mean": 1.0, "end": 0.0}),  # too close: kept
            _row("held", "held", {"held": 0.0, "mean": 20.0}),  # decided, right
            _row("held", "held", {})]  # the equation group decided
    assert [mc.rule_pick(r, 3.84) for r in rows] == ["mean", "held", "held", "held"]
    assert [mc.rule_pick(r, 6.63) for r in rows] == ["held", "held", "held", "held"]
    path = tmp_path / "null.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    table = mc.null_summary([str(path)], leads=(3.84, 6.63))
    # all rows: 4 records, 3 undecided by Eq. 10, 2 read wrong today; at 3.84 1 wrong of
    # 2 decided, at 6.63 2 wrong of 1 decided
    assert "| all | all | 4 | 3 | 2 | 1 / 2 | 2 / 1 |" in table


def test_scan_refuses_an_unread_set_before_any_work(monkeypatch):
    """``scan`` reads read sets only (130000-300000): a never-seen draw is not spent."""
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_conventions as mc

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mc, "scan", never)
    with pytest.raises(SystemExit, match="--seed-base must be a read benchmark set"):
        mc.main(["scan", "--seed-base", "310000", "--out", "rows.jsonl"])
