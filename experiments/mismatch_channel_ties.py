"""Named effects whose channel the data barely chose, read from kept benchmark reports.

    python experiments/mismatch_channel_ties.py OUT_DIR [OUT_DIR ...]

Each ``OUT_DIR`` is a ``mismatch_benchmark.py --realistic --out`` folder (or any folder
above some): every ``*.report.json`` with its ``*.truth.json`` beside it is read once per
file name (an arm run twice counts once).  For each named effect with the same effect on
another channel among its ``evidence.alternatives`` within ``AMBIGUOUS_DBIC``, the
margin (its dBIC less the best such alternative's) is listed under: the named channel
is the truth's, the alternative's channel is, or neither (an out-of-catalogue truth or a
clean record).  Why: in the equation group's f_B-free rows a bias drift on x1 and one on
y2 can fit one slow change within a BIC unit (docs/mismatch.md 9.18, 9.7's thirty-third
run), and the report then names one channel with no caveat.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tmopt.mismatch.calibration import AMBIGUOUS_DBIC


def _pairs(folders: list[Path]) -> dict[str, tuple[Path, Path]]:
    out = {}
    for folder in folders:
        for rep in sorted(folder.rglob("*.report.json")):
            truth = rep.with_name(rep.name.replace(".report.json", ".truth.json"))
            if truth.exists():
                out.setdefault(rep.name, (rep, truth))
    return out


def margins(folders: list[Path]) -> dict[str, list[tuple[float, str]]]:
    """``{"named", "alternative", "neither"}`` -> [(margin, record)] (see the module)."""
    out: dict[str, list[tuple[float, str]]] = {"named": [], "alternative": [], "neither": []}
    for name, (rep_path, truth_path) in _pairs(folders).items():
        rep, truth = json.loads(rep_path.read_text()), json.loads(truth_path.read_text())
        true = {(e["name"], e.get("tool_channel")) for e in truth.get("effects", [])}
        for e in rep.get("effects", []):
            dbic = e["evidence"]["delta_bic"]
            close = [a for a in e["evidence"].get("alternatives", [])
                     if a["name"] == e["name"] and a["channel"] != e["channel"]
                     and dbic - a["delta_bic"] < AMBIGUOUS_DBIC]  # fmt: skip
            if not close:
                continue
            margin = dbic - max(a["delta_bic"] for a in close)
            label = f"{name.split('.')[0]} {e['name']}[{e['channel']}]"
            if (e["name"], e["channel"]) in true:
                out["named"].append((margin, label))
            elif any((a["name"], a["channel"]) in true for a in close):
                out["alternative"].append((margin, label))
            else:
                out["neither"].append((margin, label))
    return out


def main(argv: list[str] | None = None) -> None:
    folders = [Path(a) for a in (sys.argv[1:] if argv is None else argv)]
    if not folders or not all(f.is_dir() for f in folders):
        raise SystemExit("usage: mismatch_channel_ties.py OUT_DIR [OUT_DIR ...] (folders)")
    print(f"{len(_pairs(folders))} reports with their truth")
    for kind, rows in margins(folders).items():
        rows.sort()
        print(f"truth at the {kind} channel: {len(rows)}; margins "
              f"{', '.join(f'{m:.2f}' for m, _ in rows)}")  # fmt: skip
        for m, label in rows:
            if m < 2.5:
                print(f"    {m:5.2f}  {label}")


if __name__ == "__main__":
    main()
