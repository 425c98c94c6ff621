"""experiments/mismatch_conventions.py's ``pinned`` and ``likelihood`` (docs/mismatch.md
9.31): bad input is refused in one line naming the parameter, before any recording is
made."""

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
