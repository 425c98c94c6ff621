"""Every algorithm on MW1, MW3, MW7, C1-DTLZ1 and C2-DTLZ2: IGD and HV over seeds.

    python experiments/compare_benchmarks.py                 # run (or resume), collect, write
    python experiments/compare_benchmarks.py --collect-only  # tables from what has finished
    python experiments/compare_benchmarks.py --dry-run       # print the sweep commands

Settings (the algorithms issue's "expensive setting"): D = 10 variables, 300 real
evaluations for every algorithm; the evolutionary baselines also with 10 000 (C-MOEA/D
then in batches of 100 children, not steady state: see --cmoead-batch). Seeds
0..SEEDS-1. Two Hydra sweeps write into one folder (multirun/<name>), which
``python -m tmopt.collect`` reads; the generated part of docs/benchmarks.md (between its
markers) is then replaced by the collected tables, the commands and the wall times,
and the hand-written reading around it is kept.

Re-running the script launches only the unfinished runs, which resume.
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PROBLEMS = ("mw1", "mw3", "mw7", "c1dtlz1", "c2dtlz2")
#: Every algorithm of the comparison; the first group is also run with the large budget.
EVOLUTIONARY = ("nsga2", "nsga3", "cmoead", "ctsea", "ssde", "cmoes")
SURROGATE_ASSISTED = ("mgsaea", "mgsaea_star", "mgsaea_ipc", "qlognehvi")
#: Run last, in their own sweep (GP fit + acquisition optimisation every iteration).
SLOW = ("qlognehvi",)
BEGIN, END = "<!-- BEGIN GENERATED: compare_benchmarks.py -->", \
    "<!-- END GENERATED: compare_benchmarks.py -->"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--n-var", type=int, default=10)
    ap.add_argument("--budget", type=int, default=300, help="expensive setting, every algorithm")
    ap.add_argument("--ea-budget", type=int, default=10_000,
                    help="evolutionary baselines again with this budget (0: skip)")
    ap.add_argument("--problems", default=",".join(PROBLEMS))
    ap.add_argument("--algorithms", default=None,
                    help="comma list (default: every algorithm of the comparison with a "
                         "tmopt/conf/algorithm file)")
    ap.add_argument("--surrogate", default="rbf", help="surrogate of the SAEAs (rbf or gp)")
    ap.add_argument("--cmoead-batch", type=int, default=100,
                    help="C-MOEA/D's batch_size at --ea-budget (1 = steady state, whose "
                         "10 000 one-design archive writes take ~15 min per run here)")
    ap.add_argument("--launcher", default="local_parallel")
    ap.add_argument("--n-jobs", type=int, default=2)
    ap.add_argument("--name", default="benchmarks", help="sweep folder multirun/<name>")
    ap.add_argument("--doc", type=Path, default=REPO / "docs" / "benchmarks.md")
    ap.add_argument("--collect-only", action="store_true")
    ap.add_argument("--dry-run", action="store_true")
    return ap.parse_args(argv)


def algorithms(args: argparse.Namespace) -> list[str]:
    wanted = args.algorithms.split(",") if args.algorithms else \
        [*EVOLUTIONARY, *SURROGATE_ASSISTED]
    present = [a for a in wanted if (REPO / "tmopt" / "conf" / "algorithm" / f"{a}.yaml").exists()]
    for a in sorted(set(wanted) - set(present)):
        print(f"note: tmopt/conf/algorithm/{a}.yaml not found; {a} is left out", file=sys.stderr)
    return present


def sweep_commands(args: argparse.Namespace) -> list[list[str]]:
    """The Hydra sweeps, cheapest first: all algorithms but the GP-based BO at --budget,
    the EAs again at --ea-budget (C-MOEA/D in its own sweep, for its batch_size), then
    qLogNEHVI (~30 s per iteration on two loaded cores), so partial results come early.
    ``algorithm`` is the first override, so Hydra runs one algorithm's runs together."""
    algos = algorithms(args)
    head = [sys.executable, "-m", "tmopt", "-m"]
    # n_var as a one-value sweep: a plain override would also be applied to the default
    # problem (stiffness, which has no n_var) when Hydra composes the sweep's base config
    tail = [f"problem={args.problems}", f"problem.n_var=choice({args.n_var})",
            f"seed=range(0,{args.seeds})", f"name={args.name}", f"surrogate={args.surrogate}",
            "plots=false", f"hydra/launcher={args.launcher}"]
    if args.launcher in ("local_parallel", "joblib"):
        tail.append(f"hydra.launcher.n_jobs={args.n_jobs}")
    cheap = [a for a in algos if a not in SLOW]
    eas = [a for a in algos if a in EVOLUTIONARY and a != "cmoead"]
    cmds = []
    if cheap:
        cmds.append([*head, f"algorithm={','.join(cheap)}", *tail, f"budget={args.budget}"])
    if args.ea_budget and eas:
        cmds.append([*head, f"algorithm={','.join(eas)}", *tail, f"budget={args.ea_budget}"])
    if args.ea_budget and "cmoead" in algos:  # its own sweep: batch_size is C-MOEA/D's key
        cmds.append([*head, "algorithm=cmoead", *tail, f"budget={args.ea_budget}",
                     f"algorithm.batch_size={args.cmoead_batch}"])
    slow = [a for a in algos if a in SLOW]
    if slow:
        cmds.append([*head, f"algorithm={','.join(slow)}", *tail, f"budget={args.budget}"])
    return cmds


def run_sweeps(cmds: list[list[str]]) -> list[tuple[str, float, int]]:
    """Run each sweep (a failing sweep does not stop the next); (command, wall s, status)."""
    env = {**os.environ, "NUMBA_NUM_THREADS": os.environ.get("NUMBA_NUM_THREADS", "1")}
    done = []
    for cmd in cmds:
        t0 = time.perf_counter()
        status = subprocess.run(cmd, cwd=REPO, env=env).returncode
        done.append((_show(cmd), time.perf_counter() - t0, status))
        print(f"== {done[-1][1]:.0f} s, exit {status}: {done[-1][0]}", file=sys.stderr)
    return done


def _show(cmd: list[str]) -> str:
    return shlex.join(["python", *cmd[1:]])


def generated_section(args: argparse.Namespace, cmds: list[list[str]],
                      timings: list[tuple[str, float, int]], collected: Path) -> str:
    """Markdown that replaces the generated part of docs/benchmarks.md."""
    lines = [BEGIN, "", f"Generated by `python experiments/compare_benchmarks.py` on "
             f"{time.strftime('%Y-%m-%d %H:%M')} (load average at the end: "
             f"{_load()}). Sweep folder `multirun/{args.name}`.", "", "Commands:", "",
             "```bash", *(_show(c) for c in cmds), f"python -m tmopt.collect multirun/"
             f"{args.name}", "```", ""]
    if timings:
        lines += ["Wall time of each sweep in this invocation (a resumed sweep counts only "
                  "what was left):", ""]
        lines += [f"- {t:.0f} s (exit {s}): `{c.split(' -m ', 1)[-1][:90]}...`"
                  for c, t, s in timings]
        lines.append("")
    for name in ("benchmarks.md", "status.md"):
        path = collected / name
        if path.exists():
            lines += [path.read_text().replace("## ", "### ", 1), ""]
    lines += ["![IGD](../multirun/" + args.name + "/collected/benchmarks_igd.png) "
              "(figures are in the sweep folder, not in git)", "", END]
    return "\n".join(lines)


def _load() -> str:
    try:
        return " ".join(f"{v:.1f}" for v in os.getloadavg())
    except OSError:
        return "n/a"


def write_doc(doc: Path, section: str) -> None:
    """Replace the generated part of ``doc`` (or append it), keeping the hand-written text."""
    text = doc.read_text() if doc.exists() else "# Benchmarks\n\n"
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        text = head + section + rest.split(END, 1)[1]
    else:
        text = text.rstrip() + "\n\n" + section + "\n"
    doc.write_text(text)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    cmds = sweep_commands(args)
    if args.dry_run:
        print("\n".join(_show(c) for c in cmds))
        return 0
    timings = [] if args.collect_only else run_sweeps(cmds)
    sweep_dir = REPO / "multirun" / args.name
    from tmopt.reporting.collect import collect

    collected = sweep_dir / "collected"
    collect(sweep_dir, collected, reference="mgsaea_ipc", fig10=False)
    write_doc(args.doc, generated_section(args, cmds, timings, collected))
    print((collected / "benchmarks.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
