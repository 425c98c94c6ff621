"""Accelerometer sampling conventions and integrators the tool may meet (docs/mismatch.md
9.25, 9.26).

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
    python experiments/mismatch_conventions.py survey --seeds 16200-16215 --conventions end \
        --duration 1200 --sample-rate 2 --stiffness 1.8e-6,-1.6e-6,1.2e-6,-1.5e-6 \
        --tool two --out results/mismatch_conventions/dev_two.jsonl   # and --tool three
    python experiments/mismatch_conventions.py bench --n 40 --tool three \
        --out results/mismatch_conventions/bench_three.jsonl   # and --tool two
    python experiments/mismatch_conventions.py bench-summary results/.../bench_three.jsonl

``bench`` runs the realistic benchmark's foreign cases (seeds from ``--seed-base``,
900000 by default: no benchmark draw's; the first ``--n`` of a fixed shuffle) with every
scenario recorded ``end``, scored as the benchmark scores (``mismatch_realistic``):
whether the tool keeps its power on such recordings, not only its silence.

A simulator may also take Euler steps and record the acceleration at the sample (the one
its step used): one ``symplectic`` step per sample (``v += h a; r += h v``) makes the
readout's second difference ``h^2 a_n``, one ``explicit`` step (``r += h v; v += h a``)
``h^2 a_{n-1}``, N sub-steps ``h^2/2 ((a_n + a_{n-1}) +- (a_n - a_{n-1})/N)``: a half-step
term beside the ZOH relation.  ``--conventions`` takes ``symplectic``, ``explicit`` and
``symplectic10`` (N = 10) etc.; ``bench --recorded symplectic`` records the benchmark's
foreign cases that way; ``--tool three`` is the tool without the half-step term (stop
49's), ``halfstep`` stop 50's (with the half-step term; the default,
``curvature``, is the shipped one):

    python experiments/mismatch_conventions.py survey --seeds 37164-37173 \
        --conventions symplectic,explicit --tool three --out before.jsonl
    python experiments/mismatch_conventions.py survey --seeds 37164-37183 \
        --conventions symplectic,explicit --out half.jsonl
    python experiments/mismatch_conventions.py survey --seeds 37164-37173 \
        --conventions symplectic10,explicit4,symplectic2 --out half.jsonl
    python experiments/mismatch_conventions.py survey --seeds 37164-37173 \
        --conventions held,mean,end --out half.jsonl
    python experiments/mismatch_conventions.py bench --n 12 --recorded symplectic \
        --out bench_sym_half.jsonl   # and --tool three; --recorded held, symplectic10

A readout may report the mean position over the step that ends at the sample (an
integrating sensor): ``+rmean`` after any of the above (``held+rmean``) records that way;
its relation is the explicit half-step term with a curvature of 1/6 (9.27).  ``--tool
halfstep`` is then stop 50's tool, ``curvature`` (the default) the shipped one:

    python experiments/mismatch_conventions.py survey --seeds 37184-37193 \
        --conventions held+rmean,mean+rmean --out rmean.jsonl   # and --tool halfstep
    python experiments/mismatch_conventions.py survey --seeds 37184-37193 \
        --conventions held --rewrite readout-mean --out trapezoid.jsonl
    python experiments/mismatch_conventions.py bench --n 12 --recorded held+rmean \
        --out bench_rmean.jsonl   # and --tool halfstep

``pinned --records foreign:300014,foreign:280012,foreign:260007 --pin chosen,mean`` diagnoses
benchmark recordings with the convention chosen from the data and pinned to each one
asked (the recording's ``acc_sampling`` attribute): three clean foreign false alarms,
all recorded ``mean`` and read otherwise, vanish when it is pinned (9.31).
``likelihood --records foreign:300014,foreign:240004`` prints the kinematic group's
profile likelihood under each convention beside the recorded and the chosen one.
``null --seeds 37400-37459 --out null.jsonl`` reads clean recordings of known convention
(kernel ``held``; foreign ``held``, ``mean``, ``end``) with that profile beside the shipped
choice; ``null-summary null.jsonl`` counts the wrong reads today and with the rule of
``Settings.convention_profile`` at each lead (9.32).

``scan --seed-base 240000`` reads the convention of every recording of a read benchmark
set with the shipped tool: the half-step and curvature terms must take none of them
(where they take none, the diagnosis is the one before them: nothing else changed);
``--backend kernel`` or ``foreign`` splits it over two processes.

Rows are JSON lines (resumable: a (seed, convention, rewrite, tool) row already written
is skipped); each row records the library versions of the run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: The tool's conventions: (ZOH accelerometer conventions, half-step term estimated,
#: curvature term estimated, an integrating readout read: ``fit.INTEGRATING_READOUT``).
#: ``curvature`` is the shipped tool (stop 51), ``halfstep`` stop 50's, ``three`` stop
#: 49's, ``two`` the one before.
_ZOH = ("held", "mean", "end")
TOOLS = {"curvature": (_ZOH, True, True, True), "halfstep": (_ZOH, True, False, False),
         "three": (_ZOH, False, False, False), "two": (("held", "mean"), False, False, False)}
#: What a recording can be made with: an accelerometer convention of the RK4 simulator, or
#: Euler steps (which record the acceleration at the sample), ``symplectic`` or
#: ``explicit`` with an optional number of sub-steps per sample (``symplectic10``); either
#: with ``+rmean``: a readout that reports the mean position over the step ending at the
#: sample (``Scenario.readout_sampling = "mean"``, docs/mismatch.md 9.27).
RECORDED = ("held", "mean", "end", "symplectic[N]", "explicit[N]", "<any>+rmean")


def _set_tool(name: str) -> None:
    import tmopt.mismatch.fit as fit

    # read at call time
    fit.ACC_CONVENTIONS, fit.HALFSTEP, fit.CURVATURE, fit.INTEGRATING_READOUT = TOOLS[name]


def _euler(convention: str) -> tuple[str, int] | None:
    """``symplectic10`` -> ("symplectic", 10); None for an RK4 convention."""
    for kind in ("symplectic", "explicit"):
        if convention.startswith(kind):
            rest = convention[len(kind):]
            if rest == "" or (rest.isdigit() and 1 <= int(rest) <= 100):
                return kind, int(rest or 1)
    return None


def _recordable(convention: str) -> bool:
    base, plus, rest = convention.partition("+")
    if plus and rest != "rmean":
        return False
    return base in ("held", "mean", "end") or _euler(base) is not None


def recorded_as(scenario, convention: str):
    """``scenario`` recorded with ``convention`` (see :data:`RECORDED`; ``+rmean``: an
    integrating readout, the step's mean position)."""
    base, _, rest = convention.partition("+")
    if rest == "rmean":
        scenario = replace(scenario, readout_sampling="mean")
    euler = _euler(base)
    if euler:
        return replace(scenario, acc_convention="held", integrator=euler[0], substeps=euler[1])
    return replace(scenario, acc_convention=base)


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    seeds = list(range(int(a), int(b or a) + 1))
    if not seeds or seeds[0] >= 40000:
        raise SystemExit(f"--seeds must be development or calibration seeds below 40000 "
                         f"(a-b); got {text!r}")
    return seeds


#: ``--rewrite``: sensor timings no simulator here makes, written over a clean recording's
#: channels from its true state: ``end-from-held`` (``held`` rewritten to read
#: ``k r(t_{n+1})``, the probe before the foreign simulator had ``end``), ``window:D`` (the
#: accelerometer's window offset by a fraction D of a step from the command grid),
#: ``readout-mean`` (the readout averaged over the step, trapezoid of the samples).
REWRITES = ("none", "end-from-held", "window:D", "readout-mean")


def rewritten(seed: int, convention: str, rewrite: str, fixed: dict | None = None):
    """A clean foreign recording (its scenario's convention replaced, ``fixed`` fields
    too) with ``rewrite``."""
    import tmopt.mismatch.realistic as R

    sc = recorded_as(R.draw_scenario(seed, "foreign", **(fixed or {})), convention)
    R._check_integrator(sc, "foreign")  # the rewrites below run the simulator directly
    if rewrite == "none":
        return sc, R.realistic_recording(sc, seed=seed, backend="foreign")[0]
    plan = R._plan(sc, (), (), seed)
    chans, state = R._run(plan, "foreign")
    kind, _, par = rewrite.partition(":")
    for a, name in enumerate(("x1", "x2", "y1", "y2")):
        acc, x = chans[f"acc_{name}"], chans[name]
        if kind == "end-from-held":
            acc[:-1] += sc.stiffness[a] * np.diff(state["r"][a])
        elif kind == "window":
            acc[1:] = (1 - float(par)) * acc[1:] + float(par) * acc[:-1]
        elif kind == "readout-mean":
            x[:-1] = 0.5 * (x[:-1] + x[1:])
    return sc, R._finish(plan, chans, state, "foreign", True)


def diagnose_clean(seed: int, convention: str, rewrite: str = "none",
                   fixed: dict | None = None, settings: dict | None = None) -> dict:
    """One clean foreign recording with its scenario's convention replaced -> a row
    (``settings``: fields of :class:`Settings` the diagnosis takes)."""
    from tmopt.mismatch.diagnose import Settings, diagnose
    from tmopt.mismatch.fit import data_from_recording
    from tmopt.mismatch.report import build_report

    sc, rec = rewritten(seed, convention, rewrite, fixed)
    t0 = time.process_time()
    rep = build_report(diagnose(data_from_recording(rec), Settings(**(settings or {}))))
    used = rep["data_used"]
    unexplained = (rep.get("unexplained_at") or {}).get("channels", []) \
        if rep.get("unexplained") else []  # fmt: skip
    names = [f"{e['name']}[{e['channel']}]" for e in rep["effects"] + rep["ambiguous"]]
    return {"seed": seed, "convention": convention, "rewrite": rewrite, "fs": sc.sample_rate,
            "stiffness": list(sc.stiffness), "status": rep["status"],
            "chosen": used.get("acc_convention"), "halfstep": used.get("kinematic_halfstep"),
            "curvature": used.get("kinematic_curvature", 0.0),
            "by": (used.get("acc_convention_evidence") or {}).get("by", "undecided"),
            "names": names, "unexplained": unexplained,
            "alarm": bool(names or unexplained or rep["status"] != "diagnosed"),
            "cpu_s": time.process_time() - t0}  # fmt: skip


def _check_fixed(args) -> None:
    if args.duration is not None and not 600 <= args.duration <= 7200:
        raise SystemExit(f"--duration must be in [600, 7200] s; got {args.duration}")
    if args.sample_rate is not None and not 1 <= args.sample_rate <= 20:
        raise SystemExit(f"--sample-rate must be in [1, 20] Hz; got {args.sample_rate}")
    if args.stiffness is not None:
        try:
            k = [float(v) for v in args.stiffness.split(",")]
        except ValueError:
            k = []
        if len(k) != 4 or any(abs(v) > 1e-5 for v in k):
            raise SystemExit("--stiffness must be four values k1,k2,k3,k4 with |k| <= 1e-5 "
                             f"s^-2; got {args.stiffness!r}")


def _fraction(text: str) -> bool:
    try:
        return 0.0 < float(text) < 1.0
    except ValueError:
        return False


def _fixed(args) -> dict:
    """Scenario fields fixed for every recording (``--duration`` etc.; gaps off with them)."""
    out: dict = {}
    if args.duration:
        out["duration"] = args.duration
    if args.sample_rate:
        out["sample_rate"] = args.sample_rate
    if args.stiffness:
        out["stiffness"] = tuple(float(v) for v in args.stiffness.split(","))
    return {**out, "gaps": ()} if out else out


def _rows_out(path: str, key) -> tuple[Path, set]:
    """``--out`` made ready (its folder created) and the resume keys ``key(row)`` of the
    rows it holds already (JSON lines; empty for a new file)."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists():
        return out, set()
    return out, {key(r) for r in map(json.loads, out.read_text().splitlines())}


def survey(args) -> None:
    from tmopt.run.outputs import library_versions

    _set_tool(args.tool)
    out, done = _rows_out(args.out, lambda r: (
        r["seed"], r["convention"], r.get("rewrite", "none"), r["tool"],
        json.dumps(r.get("settings", {}), sort_keys=True)))  # fmt: skip
    # one --out per set of fixed fields: the resume key does not hold them
    versions = library_versions()
    asked = json.dumps(args.settings, sort_keys=True)
    todo = [(s, c) for s in _seeds(args.seeds) for c in args.conventions.split(",")
            if (s, c, args.rewrite, args.tool, asked) not in done]  # fmt: skip
    for i, (seed, conv) in enumerate(todo, 1):
        row = {**diagnose_clean(seed, conv, args.rewrite, _fixed(args), args.settings),
               "tool": args.tool, "settings": args.settings, "fixed": _fixed(args),
               "versions": versions}  # fmt: skip
        with out.open("a") as fh:
            fh.write(json.dumps(row) + "\n")
        print(f"[{i}/{len(todo)}] {seed} {conv}: chosen {row['chosen']} ({row['by']}); "
              f"{'ALARM ' + str(row['names'] + row['unexplained']) if row['alarm'] else 'clean'}",
              flush=True)  # fmt: skip


def _tool(row: dict) -> str:
    """A survey row's tool with the settings it diagnosed with (``curvature
    convention_profile=True``)."""
    extra = " ".join(f"{k}={v}" for k, v in sorted(row.get("settings", {}).items()))
    return f"{row['tool']} {extra}".strip()


def summary(paths: list[str]) -> str:
    rows = [json.loads(line) for p in paths for line in Path(p).read_text().splitlines()]
    lines = ["| tool | recorded convention | rewrite | recordings | alarms | "
             "chosen held / mean / end / with a half-step term [min, max] | "
             "with a curvature term [min, max] |",
             "|---|---|---|---|---|---|---|"]  # fmt: skip
    keys = sorted({(_tool(r), r["convention"], r.get("rewrite", "none")) for r in rows})
    for tool, conv, rw in keys:
        sel = [r for r in rows if (_tool(r), r["convention"], r.get("rewrite", "none"))
               == (tool, conv, rw)]  # fmt: skip
        chosen = Counter(r["chosen"] if not r.get("halfstep") else "halfstep" for r in sel)
        steps = sorted(round(r["halfstep"], 3) for r in sel if r.get("halfstep"))
        curv = sorted(round(r["curvature"], 3) for r in sel if r.get("curvature"))
        lines.append(f"| {tool} | {conv} | {rw} | {len(sel)} | {sum(r['alarm'] for r in sel)} "
                     f"| {' / '.join(str(chosen[c]) for c in ('held', 'mean', 'end'))} / "
                     f"{chosen['halfstep']} {steps[:1] + steps[-1:] if steps else ''} | "
                     f"{len(curv)} {curv[:1] + curv[-1:] if curv else ''} |")
    alarms = [r for r in rows if r["alarm"]]
    lines += ["", "Alarms:"] + [f"- {_tool(r)} {r['convention']} {r.get('rewrite', 'none')} "
                                f"{r['seed']} (fs {r['fs']}): {r['names'] + r['unexplained']}"
                                for r in alarms]  # fmt: skip
    return "\n".join(lines)


def bench(args) -> None:
    import numpy as np
    from mismatch_realistic import cases, run_case

    import tmopt.mismatch.realistic as realistic

    _set_tool(args.tool)
    drawn = realistic.draw_scenario

    def recorded(seed, backend="kernel", **fixed):  # every scenario recorded as asked
        return recorded_as(drawn(seed, backend, **fixed), args.recorded)

    realistic.draw_scenario = recorded  # build() imports it at call time
    todo = cases("foreign", args.seed_base, False, realistic.SCALER_VERSION)
    todo = [todo[i] for i in np.random.default_rng(0).permutation(len(todo))[: args.n]]
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = {json.loads(x)["seed"] for x in out.read_text().splitlines()} if out.exists() else set()
    for i, case in enumerate([c for c in todo if c["seed"] not in done], 1):
        row = {**run_case(case), "tool": args.tool, "recorded": args.recorded}
        with out.open("a") as fh:
            fh.write(json.dumps(row, default=str) + "\n")
        print(f"[{i}] {case['seed']} {row.get('truth')}: found {row.get('found')!r} "
              f"unexplained {row.get('unexplained_channels')!r}", flush=True)  # fmt: skip


def scan(args) -> None:
    """The convention the shipped tool reads (``prepare``: the path of every diagnosis) on
    each recording of a benchmark set, made as the benchmark makes it (the SNR scaler of
    today, the read sets' from 130000 on) -- whether the half-step term takes any
    recording they hold (where it takes none, the diagnosis is the one before it:
    nothing else changed).  Each row also keeps the kinematic group's profile among the
    conventions the equation group left (``behind``) and the convention
    ``Settings.convention_profile`` reads (``rule``, docs 9.32); ``--category`` keeps one
    category of the set (``clean``, ...)."""
    from mismatch_realistic import _made, cases

    from tmopt.mismatch import calibration as cal
    from tmopt.mismatch.realistic import SCALER_VERSION

    out, done = _rows_out(args.out, lambda r: (r["backend"], r["seed"]))
    backends = ("kernel", "foreign") if args.backend == "both" else (args.backend,)
    todo = [c for b in backends
            for c in cases(b, args.seed_base, False, SCALER_VERSION)
            if (c["backend"], c["seed"]) not in done
            and args.category in ("all", c["category"])]  # fmt: skip
    for i, case in enumerate(todo, 1):
        try:
            rec, truth = _made(case)[:2]
        except Exception as exc:  # a diverged loop is reported, as the benchmark does
            row = {"backend": case["backend"], "seed": case["seed"],
                   "error": f"generation: {type(exc).__name__}: {exc}"}
            with out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(f"[{i}/{len(todo)}] {case['backend']} {case['seed']}: {row['error']}")
            continue
        data, left, behind = read_before_rule(rec)  # ``rule``: the read with it
        ev = data.usage.get("acc_convention_evidence", {}).get("halfstep_evidence", {})
        row = {"backend": case["backend"], "seed": case["seed"], "category": case["category"],
               "recorded": truth["scenario"].get("acc_convention"),
               "chosen": data.acc_convention, "left": left, "behind": behind,
               "rule": rule_pick({"chosen": data.acc_convention, "behind": behind},
                                 cal.CONVENTION_LEAD),
               "halfstep": data.halfstep,
               "evidence": ev.get("combined"), "curvature": data.curvature,
               "curvature_evidence": data.usage.get("acc_convention_evidence", {}).get(
                   "curvature_evidence", {}).get("combined")}  # fmt: skip
        with out.open("a") as fh:
            fh.write(json.dumps(row) + "\n")
        print(f"[{i}/{len(todo)}] {case['backend']} {case['seed']}: recorded "
              f"{row['recorded']}, chosen {row['chosen']} (rule: {row['rule']}), half-step "
              f"{row['halfstep']} "
              f"({row['evidence']}), curvature {row['curvature']} "
              f"({row['curvature_evidence']})", flush=True)


def pinned(args) -> None:
    """Benchmark recordings (``backend:seed``, made as the benchmark makes them) diagnosed
    with the accelerometer convention chosen from the data (``chosen``) and pinned by the
    recording's ``acc_sampling`` attribute to each convention asked: what a clean record's
    finding owes to the convention the tool kept undecided (docs/mismatch.md 9.31)."""
    from mismatch_realistic import case_recording

    from tmopt.mismatch.diagnose import diagnose
    from tmopt.mismatch.fit import ACC_ATTRIBUTE, data_from_recording
    from tmopt.mismatch.report import build_report
    from tmopt.run.outputs import library_versions

    out, done = _rows_out(args.out, lambda r: (r["backend"], r["seed"], r["pin"]))
    versions = library_versions()
    for backend, seed in _records(args.records):
        rec, truth = case_recording(backend, seed)
        for pin in args.pin.split(","):
            if (backend, seed, pin) in done:
                continue
            rec.attrs.pop(ACC_ATTRIBUTE, None)
            if pin != "chosen":
                rec.attrs[ACC_ATTRIBUTE] = pin
            t = time.process_time()
            rep = build_report(diagnose(data_from_recording(rec)))
            row = {"backend": backend, "seed": seed, "pin": pin,
                   "recorded": truth["scenario"].get("acc_convention"),
                   "read": rep["data_used"].get("acc_convention"),
                   "names": [f"{e['name']}[{e['channel']}]" for e in rep["effects"]],
                   "unexplained": rep["unexplained_at"]["channels"] if rep["unexplained"]
                   else [],
                   "features": [[f["feature"], f["channel"], f["evidence"]["glr"]]
                                for f in rep["features"]],
                   "alarm": bool(rep["mismatch_detected"]),
                   "cpu_s": time.process_time() - t, "versions": versions}  # fmt: skip
            with out.open("a") as fh:
                fh.write(json.dumps(row) + "\n")
            print(f"{backend} {seed} pinned {pin} (recorded {row['recorded']}, read "
                  f"{row['read']}): names {row['names']}, unexplained {row['unexplained']}, "
                  f"features {row['features']}", flush=True)  # fmt: skip


def likelihood(args) -> None:
    """Benchmark recordings (``backend:seed``) read under each accelerometer convention
    (:func:`tmopt.mismatch.diagnose.convention_profile`: the kinematic group's nominal
    Whittle log-likelihood, its noise model estimated under each); printed as ``2 dl``
    behind the best convention, beside the recorded one and the one the tool chose
    before ``convention_profile`` (docs/mismatch.md 9.31)."""
    from mismatch_realistic import case_recording

    for backend, seed in _records(args.records):
        rec, truth = case_recording(backend, seed)
        data, _, behind = read_before_rule(rec, _ZOH)
        behind = {c: round(v, 1) for c, v in behind.items()}
        print(f"{backend} {seed}: recorded {truth['scenario'].get('acc_convention')}, chosen "
              f"{data.acc_convention}; 2 dl behind the best: {behind}", flush=True)  # fmt: skip


def read_before_rule(rec, among=None):
    """``rec`` prepared as the tool read it before ``Settings.convention_profile`` ->
    (data, the conventions the equation group left, the kinematic profile among
    ``among`` -- default those left -- or {} where fewer than two are compared)."""
    from tmopt.mismatch.diagnose import Settings, convention_profile, prepare
    from tmopt.mismatch.fit import data_from_recording

    data, _ = prepare(data_from_recording(rec), settings=Settings(convention_profile=False))
    left = data.usage["acc_convention_evidence"].get("left", [])
    among = left if among is None else among
    behind = convention_profile(data, data.stiffness, among) if len(among) > 1 else {}
    return data, left, behind


#: What the null records: the kernel records ``held`` only; the foreign simulator each.
NULL_RECORDED = {"kernel": ("held",), "foreign": _ZOH}


def null(args) -> None:
    """The null of ``Settings.convention_profile`` (docs/mismatch.md 9.32): clean
    recordings of known convention (calibration seeds; the kernel's ``held``, the foreign
    simulator's scenario recorded ``held``, ``mean`` and ``end``) read as the tool read them
    before the rule (:func:`prepare`, ``convention_profile`` off), with the kinematic
    group's profile likelihood among the
    conventions the equation group left (:func:`convention_profile`).  Each row keeps the
    profile, so the rule's pick at any lead is read from the rows (``null-summary``)."""
    import tmopt.mismatch.realistic as R
    from tmopt.run.outputs import library_versions

    out, done = _rows_out(args.out, lambda r: (r["backend"], r["seed"], r["recorded"]))
    versions = library_versions()
    todo = [(b, s, c) for s in _seeds(args.seeds) for b in args.backends.split(",")
            for c in NULL_RECORDED[b] if (b, s, c) not in done]  # fmt: skip
    for i, (backend, seed, conv) in enumerate(todo, 1):
        t0 = time.process_time()
        sc = R.draw_scenario(seed, backend)
        sc = recorded_as(sc, conv) if backend == "foreign" else sc
        # ``chosen``: the read before the rule; the rule's read follows from ``behind``
        data, left, behind = read_before_rule(R.realistic_recording(sc, seed=seed,
                                                                    backend=backend)[0])
        ev = data.usage["acc_convention_evidence"]
        row = {"backend": backend, "seed": seed, "recorded": conv, "fs": sc.sample_rate,
               "chosen": data.acc_convention, "by": ev.get("by", "undecided"), "left": left,
               "behind": behind, "cpu_s": time.process_time() - t0, "versions": versions}
        with out.open("a") as fh:
            fh.write(json.dumps(row) + "\n")
        print(f"[{i}/{len(todo)}] {backend} {seed} {conv}: chosen {row['chosen']} "
              f"({row['by']}); profile behind {({c: round(v, 1) for c, v in behind.items()})}",
              flush=True)  # fmt: skip


def rule_pick(row: dict, lead: float) -> str:
    """The convention ``Settings.convention_profile`` picks on a ``null`` row at ``lead``."""
    from tmopt.mismatch.diagnose import profile_pick

    return profile_pick(row["behind"], lead) or row["chosen"]


def null_summary(paths: list[str], leads=(3.84, 6.63, 10.0)) -> str:
    """Per backend and recorded convention: today's wrong reads, and the rule's wrong reads
    and decisions at each lead."""
    from tmopt.mismatch.diagnose import profile_pick

    rows = [json.loads(x) for p in paths for x in Path(p).read_text().splitlines()]
    head = " | ".join(f"rule at {v:g}: wrong / decided" for v in leads)
    lines = [f"| backend | recorded | records | undecided by Eq. 10 | today wrong | {head} |",
             "|---|---|---|---|---|" + "---|" * len(leads)]
    keys = sorted({(r["backend"], r["recorded"]) for r in rows}) + [("all", "all")]
    for b, c in keys:
        sel = [r for r in rows
               if (b, c) in (("all", "all"), (r["backend"], r["recorded"]))]  # fmt: skip
        cells = []
        for v in leads:
            wrong = sum(rule_pick(r, v) != r["recorded"] for r in sel)
            decided = sum(profile_pick(r["behind"], v) is not None for r in sel)
            cells.append(f"{wrong} / {decided}")
        today = sum(r["chosen"] != r["recorded"] for r in sel)
        undecided = sum(len(r["left"]) > 1 for r in sel)
        lines.append(f"| {b} | {c} | {len(sel)} | {undecided} | {today} | {' | '.join(cells)} |")
    return "\n".join(lines)


def _among(flag: str, text: str, allowed: tuple[str, ...]) -> None:
    """A comma-separated ``flag`` whose items must be among ``allowed``: SystemExit naming
    it and the ones that are not."""
    bad = sorted(set(text.split(",")) - set(allowed))
    if bad:
        raise SystemExit(f"{flag} must be among {', '.join(allowed)}; got {bad}")


def _records(text: str) -> list[tuple[str, int]]:
    """``--records`` read by :func:`mismatch_realistic.parse_records`."""
    from mismatch_realistic import parse_records

    return parse_records(text)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sv = sub.add_parser("survey")
    sv.add_argument("--seeds", required=True, help="calibration seeds a-b (< 40000)")
    sv.add_argument("--conventions", default="held,mean,end")
    sv.add_argument("--tool", choices=sorted(TOOLS), default="curvature")
    sv.add_argument("--rewrite", default="none", help=f"one of {REWRITES} (D in (0, 1))")
    sv.add_argument("--duration", type=float, help="fixed record length [s], 600-7200")
    sv.add_argument("--sample-rate", type=float, help="fixed rate [Hz], 1-20")
    sv.add_argument("--stiffness", help="fixed k of x1,x2,y1,y2 [s^-2], each |k| <= 1e-5")
    sv.add_argument("--setting", action="append", default=None, metavar="NAME=VALUE",
                    help="diagnose with this tool setting (a field of Settings, e.g. "
                         "convention_profile=true; repeatable; part of the resume key)")
    sv.add_argument("--out", required=True)
    sm = sub.add_parser("summary")
    sm.add_argument("rows", nargs="+")
    bn = sub.add_parser("bench")
    bn.add_argument("--n", type=int, default=40, help="cases, 1-150")
    bn.add_argument("--seed-base", type=int, default=900000)
    bn.add_argument("--tool", choices=sorted(TOOLS), default="curvature")
    bn.add_argument("--recorded", default="end", help=f"one of {RECORDED}")
    bn.add_argument("--out", required=True)
    sc = sub.add_parser("scan")
    sc.add_argument("--seed-base", type=int, required=True, help="a read set, e.g. 240000")
    sc.add_argument("--backend", choices=["kernel", "foreign", "both"], default="both")
    sc.add_argument("--category", default="all",
                    help="all, or one category of the set (clean, catalogue, pair, ...)")
    sc.add_argument("--out", required=True)
    bs = sub.add_parser("bench-summary")
    bs.add_argument("rows")
    pn = sub.add_parser("pinned")
    pn.add_argument("--records", required=True, help="SEED or BACKEND:SEED, comma-separated")
    pn.add_argument("--pin", default="chosen,held,mean,end",
                    help="chosen and/or conventions among held, mean, end")
    pn.add_argument("--out", required=True)
    lk = sub.add_parser("likelihood")
    lk.add_argument("--records", required=True, help="SEED or BACKEND:SEED, comma-separated")
    nl = sub.add_parser("null")
    nl.add_argument("--seeds", required=True, help="calibration seeds a-b (< 40000)")
    nl.add_argument("--backends", default="kernel,foreign", help="kernel and/or foreign")
    nl.add_argument("--out", required=True)
    ns = sub.add_parser("null-summary")
    ns.add_argument("rows", nargs="+")
    args = ap.parse_args(argv)
    if args.cmd == "null":
        _among("--backends", args.backends, tuple(NULL_RECORDED))
        _seeds(args.seeds)
        null(args)
        return 0
    if args.cmd == "null-summary":
        print(null_summary(args.rows))
        return 0
    if args.cmd == "likelihood":
        _records(args.records)
        likelihood(args)
        return 0
    if args.cmd == "pinned":
        _among("--pin", args.pin, ("chosen", *_ZOH))
        _records(args.records)
        pinned(args)
        return 0
    if args.cmd == "bench":
        if not _recordable(args.recorded):
            raise SystemExit(f"--recorded must be one of {RECORDED} (N in 1-100); "
                             f"got {args.recorded!r}")
        if not 1 <= args.n <= 150:
            raise SystemExit(f"--n must be in [1, 150]; got {args.n}")
        bench(args)
        return 0
    if args.cmd == "scan":
        if args.seed_base % 10000 or not 130000 <= args.seed_base <= 300000:
            raise SystemExit("--seed-base must be a read benchmark set of today's SNR scaler, "
                             f"130000-300000 in steps of 10000; got {args.seed_base}")
        scan(args)
        return 0
    if args.cmd == "bench-summary":
        from mismatch_realistic import summarise

        print(summarise([json.loads(x) for x in Path(args.rows).read_text().splitlines()]))
        return 0
    if args.cmd == "survey":
        bad = [c for c in args.conventions.split(",") if not _recordable(c)]
        if bad:
            raise SystemExit(f"--conventions must be among {RECORDED}; got {sorted(bad)}")
        kind, _, par = args.rewrite.partition(":")
        if args.rewrite not in REWRITES and not (kind == "window" and _fraction(par)):
            raise SystemExit(f"--rewrite must be one of {REWRITES} with D in (0, 1); "
                             f"got {args.rewrite!r}")  # fmt: skip
        _check_fixed(args)
        from mismatch_realistic import parse_settings

        try:
            args.settings = parse_settings(args.setting)
        except ValueError as exc:
            raise SystemExit(str(exc)) from None
        if kind == "end-from-held" and args.conventions != "held":
            raise SystemExit("--rewrite end-from-held rewrites a held accelerometer: "
                             f"--conventions must be held; got {args.conventions!r}")
        survey(args)
    else:
        print(summary(args.rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
