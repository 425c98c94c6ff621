"""Accelerometer sampling conventions the tool may meet (docs/mismatch.md 9.25).

A simulator can read its accelerometer's stiffness term at the step's start (``held``,
the kernel's), as the step's mean (``mean``, the foreign default) or after the step
(``end``: ``k r(t_{n+1}) + u_n``, what code that measures after the state update
records).  The three differ by ``~k v h/2`` steps, which at flight-like |k| ~ 1e-6 s^-2
the kinematic group sees.  This survey diagnoses clean foreign recordings (calibration
seeds, each scenario's convention replaced by the one asked for) with the tool as it
is and with its conventions cut to the two it had before stop 49 (``--tool two``), and
counts the alarms and the conventions chosen.

    python experiments/mismatch_conventions.py survey --seeds 37144-37163 \
        --conventions end,held,mean --tool three --out results/mismatch_conventions/three.jsonl
    python experiments/mismatch_conventions.py survey --seeds 37144-37163 \
        --conventions end --tool two --out results/mismatch_conventions/two.jsonl
    python experiments/mismatch_conventions.py summary results/mismatch_conventions/*.jsonl

Rows are JSON lines (resumable: a (seed, convention, tool) row already written is
skipped); each row records the library versions of the run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

TOOLS = {"three": ("held", "mean", "end"), "two": ("held", "mean")}


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    seeds = list(range(int(a), int(b or a) + 1))
    if not seeds or seeds[0] >= 40000:
        raise SystemExit(f"--seeds must be calibration seeds below 40000 (a-b); got {text!r}")
    return seeds


def diagnose_clean(seed: int, convention: str) -> dict:
    """One clean foreign recording with its scenario's convention replaced -> a row."""
    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.realistic import draw_scenario, realistic_recording
    from tmopt.mismatch.report import build_report

    sc = replace(draw_scenario(seed, "foreign"), acc_convention=convention)
    rec, _ = realistic_recording(sc, seed=seed, backend="foreign")
    t0 = time.process_time()
    rep = build_report(diagnose(data_from_recording(rec)))
    used = rep["data_used"]
    unexplained = (rep.get("unexplained_at") or {}).get("channels", []) \
        if rep.get("unexplained") else []  # fmt: skip
    names = [f"{e['name']}[{e['channel']}]" for e in rep["effects"] + rep["ambiguous"]]
    return {"seed": seed, "convention": convention, "fs": sc.sample_rate,
            "stiffness": list(sc.stiffness), "status": rep["status"],
            "chosen": used.get("acc_convention"),
            "by": (used.get("acc_convention_evidence") or {}).get("by", "undecided"),
            "names": names, "unexplained": unexplained,
            "alarm": bool(names or unexplained or rep["status"] != "diagnosed"),
            "cpu_s": time.process_time() - t0}  # fmt: skip


def survey(args) -> None:
    import tmopt.mismatch.fit as fit
    from tmopt.run.outputs import library_versions

    fit.ACC_CONVENTIONS = TOOLS[args.tool]  # the tool's list, read at call time
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if out.exists():
        done = {(r["seed"], r["convention"], r["tool"])
                for r in map(json.loads, out.read_text().splitlines())}  # fmt: skip
    versions = library_versions()
    todo = [(s, c) for s in _seeds(args.seeds) for c in args.conventions.split(",")
            if (s, c, args.tool) not in done]  # fmt: skip
    for i, (seed, conv) in enumerate(todo, 1):
        row = {**diagnose_clean(seed, conv), "tool": args.tool, "versions": versions}
        with out.open("a") as fh:
            fh.write(json.dumps(row) + "\n")
        print(f"[{i}/{len(todo)}] {seed} {conv}: chosen {row['chosen']} ({row['by']}); "
              f"{'ALARM ' + str(row['names'] + row['unexplained']) if row['alarm'] else 'clean'}",
              flush=True)  # fmt: skip


def summary(paths: list[str]) -> str:
    rows = [json.loads(line) for p in paths for line in Path(p).read_text().splitlines()]
    lines = ["| tool | recorded convention | recordings | alarms | chosen held / mean / end |",
             "|---|---|---|---|---|"]
    for tool in sorted({r["tool"] for r in rows}):
        for conv in sorted({r["convention"] for r in rows if r["tool"] == tool}):
            sel = [r for r in rows if r["tool"] == tool and r["convention"] == conv]
            chosen = Counter(r["chosen"] for r in sel)
            lines.append(f"| {tool} | {conv} | {len(sel)} | {sum(r['alarm'] for r in sel)} | "
                         f"{chosen['held']} / {chosen['mean']} / {chosen['end']} |")
    alarms = [r for r in rows if r["alarm"]]
    lines += ["", "Alarms:"] + [f"- {r['tool']} {r['convention']} {r['seed']} (fs {r['fs']}): "
                                f"{r['names'] + r['unexplained']}" for r in alarms]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sv = sub.add_parser("survey")
    sv.add_argument("--seeds", required=True, help="calibration seeds a-b (< 40000)")
    sv.add_argument("--conventions", default="held,mean,end")
    sv.add_argument("--tool", choices=sorted(TOOLS), default="three")
    sv.add_argument("--out", required=True)
    sm = sub.add_parser("summary")
    sm.add_argument("rows", nargs="+")
    args = ap.parse_args(argv)
    if args.cmd == "survey":
        bad = set(args.conventions.split(",")) - set(TOOLS["three"])
        if bad:
            raise SystemExit(f"--conventions must be among {TOOLS['three']}; got {sorted(bad)}")
        survey(args)
    else:
        print(summary(args.rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
