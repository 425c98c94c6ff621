"""experiments/mismatch_channel_ties.py (docs/mismatch.md 9.7, thirty-third run): a named
effect with the same effect on another channel within AMBIGUOUS_DBIC is classed by where
the truth is, once per report name; experiments/mismatch_length_scaling.py and
mismatch_first_step.py refuse bad input in one line before any recording is made."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture
def ties(monkeypatch):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_channel_ties

    return mismatch_channel_ties


def _write(folder: Path, stem: str, named: str, dbic: float, alts: list[tuple[str, float]],
           truth: list[str]) -> None:  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    effect = {"name": "bias_drift", "channel": named,
              "evidence": {"delta_bic": dbic,
                           "alternatives": [{"name": "bias_drift", "channel": c, "delta_bic": d}
                                            for c, d in alts]}}  # fmt: skip
    (folder / f"{stem}.report.json").write_text(json.dumps({"effects": [effect]}))
    (folder / f"{stem}.truth.json").write_text(json.dumps(
        {"effects": [{"name": "bias_drift", "tool_channel": c} for c in truth]}))


def test_each_tie_is_classed_by_where_the_truth_is(ties, tmp_path):
    _write(tmp_path / "a", "kernel_catalogue_1", "x1", 12.0, [("y2", 11.0)], ["x1"])
    _write(tmp_path / "a", "kernel_catalogue_2", "y2", 12.0, [("x1", 10.5)], ["x1"])
    _write(tmp_path / "a", "kernel_clean_3", "x2", 9.0, [("y1", 8.0)], [])
    _write(tmp_path / "a", "kernel_catalogue_4", "x1", 20.0, [("y2", 10.0)], ["x1"])  # no tie
    _write(tmp_path / "b", "kernel_catalogue_1", "y2", 12.0, [("x1", 11.0)], ["x1"])  # a rerun
    m = ties.margins([tmp_path])
    assert [round(x, 6) for x, _ in m["named"]] == [1.0]  # the rerun of record 1 not counted
    assert [round(x, 6) for x, _ in m["alternative"]] == [1.5]
    assert [round(x, 6) for x, _ in m["neither"]] == [1.0]


def test_channel_ties_refuses_a_missing_folder(ties, tmp_path):
    with pytest.raises(SystemExit, match="OUT_DIR"):
        ties.main([str(tmp_path / "nowhere")])


@pytest.mark.parametrize(("args", "named"), [
    (["--durations", "100,1800"], "--durations"),
    (["--fs", "200"], "--fs"),
])  # fmt: skip
def test_length_scaling_refuses_bad_input_before_any_work(monkeypatch, capsys, args, named):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_length_scaling as mls

    def never(_):
        raise AssertionError("work started")

    monkeypatch.setattr(mls, "_one", never)
    with pytest.raises(SystemExit):
        mls.main(args)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert named in err


@pytest.mark.parametrize(("args", "named"), [
    (["--records", "kernel:12"], "--records: seeds must be benchmark seeds"),
    (["--records", "moon:340140"], "--records"),
    (["--records", "kernel:340140", "--top", "0"], "--top"),
    (["--records", "kernel:340140", "--setting", "nonsense=1"], "--setting"),
])  # fmt: skip
def test_first_step_refuses_bad_input_before_any_work(monkeypatch, args, named):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_first_step
    import mismatch_realistic

    def never(*_):
        raise AssertionError("work started")

    monkeypatch.setattr(mismatch_realistic, "case_recording", never)
    with pytest.raises(SystemExit, match=named) as exc:
        mismatch_first_step.main(args)
    assert "\n" not in str(exc.value)
