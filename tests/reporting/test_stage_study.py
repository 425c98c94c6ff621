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
