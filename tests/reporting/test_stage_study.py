"""experiments/stage_study.py's compact table: the setting column names what differs."""

from __future__ import annotations

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "stage_study.py"


def _module():
    spec = importlib.util.spec_from_file_location("stage_study", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_compact_names_the_keys_off_the_reference_and_orders_defaults_first():
    keys = ["problem", "algorithm.reference", "algorithm.nan_ties"]
    ref = {"algorithm.reference": "tmopt", "algorithm.nan_ties": "False"}
    header = [*keys, "runs", "IGD", "p (IGD)"]
    rows = [["mw3", "platemo", "False", "5", "0.05", "0.032"],
            ["mw3", "tmopt", "True", "5", "0.04", "0.5"],
            ["mw3", "tmopt", "False", "5", "0.04", ""],
            ["lircmop6", "tmopt", "False", "5", "0.3", ""]]
    head, out = _module()._compact(header, rows, keys, ref)
    assert head == ["problem", "setting", "runs", "IGD", "p (IGD)"]
    assert [r[:2] for r in out] == [["lircmop6", "tmopt defaults"], ["mw3", "tmopt defaults"],
                                    ["mw3", "nan_ties=True"], ["mw3", "reference=platemo"]]
    assert out[3][2:] == ["5", "0.05", "0.032"]


def test_paired_columns_test_each_setting_against_the_reference_by_seed(tmp_path, capsys):
    from tests.reporting.test_collect import _run

    # B is worse than A by 1 + seed/10 in IGD on each of seeds 0-4 (A's seed-4 run is
    # incomplete, so 4 pairs); the HV values are equal seed by seed.
    for seed in range(5):
        _run(tmp_path, f"a{seed}", {"algorithm": "ctsea", "seed": seed}, algorithm="ctsea",
             seed=seed, problem="mw3", m=None, igd=float(seed), hv=0.5,
             status="incomplete" if seed == 4 else "complete")
        _run(tmp_path, f"b{seed}", {"algorithm": "cmoes", "seed": seed}, algorithm="cmoes",
             seed=seed, problem="mw3", m=None, igd=seed + 1 + seed / 10, hv=0.5)
    assert _module().main([str(tmp_path), "--keys", "problem,algorithm",
                           "--reference", "algorithm=ctsea", "--paired"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith("| p paired (IGD) | p paired (HV) |")
    assert "stage two" not in lines[0]  # no MGSAEA-family run
    cells = [[c.strip() for c in line.split("|")[1:-1]] for line in lines[2:]]
    rows = {row[1]: row for row in cells}
    assert rows["cmoes"][-2:] == [f"{2 / 16:.3f}", "1.000"]
    assert rows["ctsea"][-2:] == ["", ""]  # the reference itself
    assert rows["cmoes"][2] == "5" and rows["ctsea"][2] == "4"
