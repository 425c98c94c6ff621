"""experiments/mismatch_acc_crosstalk_null.py (docs/mismatch.md 9.37): bad input is
refused in one line before any recording is made; the summary reads what the rows hold."""

from __future__ import annotations

from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture
def accnull(monkeypatch):
    monkeypatch.syspath_prepend(str(EXPERIMENTS))
    import mismatch_acc_crosstalk_null

    return mismatch_acc_crosstalk_null


@pytest.mark.parametrize("spec", ["kernel", "other:5", "foreign:x"])
def test_reseed_refuses_a_bad_recording_name(accnull, capsys, tmp_path, spec):
    out = tmp_path / "rows.jsonl"
    assert accnull.main(["--reseed", spec, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--reseed" in err[0] and repr(spec) in err[0]
    assert not out.exists()  # nothing was run


def test_bad_count_is_refused(accnull, capsys, tmp_path):
    assert accnull.main(["--n", "0", "--out", str(tmp_path / "r.jsonl")]) == 2
    assert "--n" in capsys.readouterr().err


def _row(glrs, z_eq, z_kin, excited=(True, False)):
    return {"candidates": 4 * len(glrs),
            "acc": [{"glr": g, "z_eq": e, "z_kin": k, "a_excited": excited[0],
                     "b_excited": excited[1]} for g, e, k in zip(glrs, z_eq, z_kin)]}  # fmt: skip


def test_summary_counts_tails_and_the_two_estimates_correlation(accnull, capsys):
    rows = [_row([1.0, 7.0], [1.0, -2.0], [2.0, -4.0]),  # z_kin = 2 z_eq: correlation 1
            _row([0.5, 12.0], [0.5, 3.0], [1.0, 6.0], excited=(False, False))]
    accnull.summarise(rows)
    text = capsys.readouterr().out
    assert "2 recordings, 4 acc cross-talk statistics; mean 5.125" in text
    assert "beyond it 0.5000 (expected 0.0100)" in text  # 7 and 12 above 6.63
    assert "beyond it 0.2500 (expected 0.0010)" in text  # 12 above 10.83
    assert "correlation of the two z-scores: 1.000 over 4" in text
    assert "the acc family's share 0.250 of the Holm level" in text
    assert "target unexcited, source unexcited: n 2, mean 6.25" in text


def test_summary_sets_the_correlated_statistic_beside_the_independent_one(accnull, capsys):
    rows = [{"candidates": 8, "acc": [
        {"glr": g, "glr_corr": gc, "rho": r, "z_eq": 1.0, "z_kin": 1.0, "a_excited": True,
         "b_excited": True} for g, gc, r in ((8.0, 6.0, 0.3), (1.0, 0.9, 0.1))]}]  # fmt: skip
    accnull.summarise(rows)
    text = capsys.readouterr().out
    assert "all (n 2, mean rho +0.200): independent mean 4.500, beyond the 0.01 level " \
        "0.5000" in text  # fmt: skip
    assert "correlated mean 3.450, beyond the 0.01 level 0.0000" in text
