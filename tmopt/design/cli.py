"""``python -m tmopt.design RECORDING_OR_REPORT --out DIR``: the excitation that separates
what a recording could not identify (docs/design.md).

RECORDING (``.h5``/``.hdf5``, or ``.csv`` with its ``.json``) is diagnosed first
(``python -m tmopt.mismatch``); a REPORT (``report.json`` of that command) gives the
"not identifiable" list and the ambiguous names with their rivals, and its recording
(the report's ``source``) the noise level (a nominal fit: conservative when effects
were selected).  Writes ``next_excitation.json``, ``design.md`` and
``next_excitation.png`` into DIR.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tmopt.design.plan import DEFAULT_ALGORITHM
from tmopt.physics.recording import AXES, RecordingError, read_recording

__all__ = ["main", "add_design_options", "check_design_options", "space_from", "design"]


def add_design_options(p: argparse.ArgumentParser) -> None:
    """The design options (shared with ``python -m tmopt.mismatch --design-next``)."""
    g = p.add_argument_group("next-excitation design")
    g.add_argument("--axes", default=",".join(AXES),
                   help="free axes, comma-separated from x1,x2,y1,y2 (default all)")
    g.add_argument("--tones", type=int, default=2, help="tones per free axis, 1..6 (2)")
    g.add_argument("--duration", default="600,2400",
                   help="identification time range [s] 'lo,hi' (600,2400)")
    g.add_argument("--effects", default=None,
                   help="only these flagged effects (comma-separated names, or name[channel] "
                        "for one channel, e.g. cubic_stiffness[x1]; default all)")
    g.add_argument("--algorithm", default=DEFAULT_ALGORITHM,
                   help="solver: a name of the algorithm registry, as python -m tmopt "
                        f"algorithm=NAME builds it, surrogate gp ({DEFAULT_ALGORITHM})")
    g.add_argument("--budget", type=int, default=None,
                   help="real evaluations (default: nsga2 --pop-size x --generations; "
                        "otherwise the algorithm's initial sample + 125)")
    g.add_argument("--pop-size", type=int, default=40, help="NSGA-II population (40)")
    g.add_argument("--generations", type=int, default=30, help="NSGA-II generations (30)")
    g.add_argument("--design-seed", type=int, default=0, help="optimiser seed (0)")


def budget_of(args: argparse.Namespace) -> int | None:
    """The budget asked for (None: the solver's default, :func:`tmopt.design.plan.solve`)."""
    if args.budget is not None:
        return args.budget
    return args.pop_size * args.generations if args.algorithm == "nsga2" else None


def check_design_options(args: argparse.Namespace) -> str | None:
    """One line naming the bad option and its range, or None (before any work)."""
    from tmopt.mismatch.effects import EFFECT_NAMES

    axes = [a.strip() for a in args.axes.split(",") if a.strip()]
    if not axes or any(a not in AXES for a in axes) or len(set(axes)) != len(axes):
        return f"--axes must be distinct names from {','.join(AXES)}; got {args.axes!r}"
    if not 1 <= args.tones <= 6:
        return f"--tones must be in [1, 6]; got {args.tones}"
    try:
        lo, hi = (float(v) for v in args.duration.split(","))
    except ValueError:
        return f"--duration must be 'lo,hi' in seconds; got {args.duration!r}"
    if not 60 <= lo <= hi <= 86400:
        return f"--duration must satisfy 60 <= lo <= hi <= 86400 s; got {args.duration!r}"
    if args.effects is not None:
        bad = [e for e in args.effects.split(",") if e.partition("[")[0] not in EFFECT_NAMES
               or ("[" in e and not e.endswith("]"))]  # fmt: skip
        if bad:
            return (f"--effects must be names (or name[channel]) from {list(EFFECT_NAMES)}; "
                    f"got {bad}")  # fmt: skip
    if not 4 <= args.pop_size <= 10000:
        return f"--pop-size must be in [4, 10000]; got {args.pop_size}"
    if not 1 <= args.generations <= 10000:
        return f"--generations must be in [1, 10000]; got {args.generations}"
    if args.design_seed < 0:
        return f"--design-seed must be >= 0; got {args.design_seed}"
    return _check_algorithm(args, len(axes))


def _check_algorithm(args: argparse.Namespace, n_axes: int) -> str | None:
    """The solver exists and the budget covers its initial sample (on a problem of the
    options' size: 3 variables a tone and the duration)."""
    from types import SimpleNamespace

    from tmopt.algorithms.base import AlgorithmConfigError
    from tmopt.run.cli import algorithm_from_registry
    from tmopt.run.config import ConfigError

    budget = budget_of(args)
    if budget is not None and not 1 <= budget <= 10**7:
        return f"--budget must be in [1, 10000000]; got {budget}"
    try:
        algo = algorithm_from_registry(args.algorithm)
        if args.algorithm != "nsga2" and budget is not None:  # nsga2: --pop-size
            shape = SimpleNamespace(n_var=3 * args.tones * n_axes + 1, name="next_excitation")
            algo.check_budget(shape, budget)
    except ConfigError as exc:
        return f"--algorithm: {exc}"
    except AlgorithmConfigError as exc:
        return f"--budget: {exc}"
    return None


def space_from(args: argparse.Namespace):
    from tmopt.design.problem import DesignSpace

    lo, hi = (float(v) for v in args.duration.split(","))
    axes = tuple(a.strip() for a in args.axes.split(",") if a.strip())
    return DesignSpace(axes=axes, tones=args.tones, duration=(lo, hi))


def design(dg, args: argparse.Namespace, out: str | Path, source: str = "",
           notes: list[str] | None = None, plots: bool = True) -> dict:  # fmt: skip
    """Design the next excitation for diagnosis ``dg`` and write it into ``out``."""
    from tmopt.design import report
    from tmopt.design.plan import plan_from_diagnosis

    effects = None if args.effects is None else args.effects.split(",")
    p = plan_from_diagnosis(dg, space_from(args), effects, algorithm=args.algorithm,
                            budget=budget_of(args), pop_size=args.pop_size,
                            seed=args.design_seed, progress=True)  # fmt: skip
    return report.write(p, out, source or dg.data.source, notes, plots)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m tmopt.design", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("input", help="recording (.h5/.hdf5/.csv) or a mismatch report.json")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG")
    add_design_options(p)
    return p


def _diagnosis_from_report(path: Path):
    """(diagnosis-like object, notes) from a report.json: its flags, its recording's
    nominal fit for the noise level."""
    from types import SimpleNamespace

    from tmopt.design.plan import NOTHING, REASONS
    from tmopt.mismatch.diagnose import Settings, evaluate, fit_state
    from tmopt.mismatch.effects import EFFECTS
    from tmopt.mismatch.fit import align_force_timing, data_from_recording, null_basis

    rep = json.loads(path.read_text())
    if "not_identifiable" not in rep or "source" not in rep:
        raise ValueError(f"{path}: not a mismatch report (no 'not_identifiable'/'source')")
    # nothing that could become a target: say so before reading the recording
    if not any(r.get("reason") in REASONS and r.get("plausible") is not None
               for r in rep["not_identifiable"]) and not any(  # fmt: skip
            r.get("feature") or r.get("name") in EFFECTS
            for a in rep.get("ambiguous", []) for r in a.get("rivals", [])) and not any(
            f.get("alternatives") for f in rep.get("features", [])):  # fmt: skip
        raise ValueError(NOTHING)
    src = Path(rep["source"])
    if not src.is_absolute() and not src.exists():
        src = path.parent / src
    if not src.is_file():  # e.g. "<memory>": a diagnosis of a recording never written
        raise ValueError(f"{path}: its recording (source {rep['source']!r}) is not a file "
                         "here; give the recording (.h5, .hdf5, .csv) instead of the report")
    data = align_force_timing(data_from_recording(read_recording(src)))
    basis = null_basis(data.geometry)
    given = rep.get("settings", {})
    settings = Settings(alpha=given.get("family_alpha", Settings.alpha),
                        locate_alpha=given.get("locate_alpha", Settings.locate_alpha))
    state = fit_state(data, basis, [], [], False, settings)
    # the diagnosis' first step tests every candidate: its Bonferroni count
    steps = [evaluate(data, basis, state, settings, set())]
    dg = SimpleNamespace(data=data, basis=basis, after=state, settings=settings,
                         not_identifiable=rep["not_identifiable"], steps=steps,
                         ambiguous=rep.get("ambiguous", []),
                         features=rep.get("features", []))  # fmt: skip
    return dg, [f"noise level from a nominal fit of {src} (the report's recording)"]


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    bad = check_design_options(args)
    if bad:
        print(f"error: {bad}", file=sys.stderr)
        return 2
    path = Path(args.input)
    if not path.exists():
        print(f"error: input {args.input!r} does not exist (a recording or a report.json)",
              file=sys.stderr)  # fmt: skip
        return 2
    notes: list[str] = []
    try:
        if path.suffix.lower() == ".json" and not path.with_suffix(".csv").exists():
            dg, notes = _diagnosis_from_report(path)
        else:
            from tmopt.mismatch.diagnose import diagnose
            from tmopt.mismatch.fit import data_from_recording

            rec = read_recording(path)
            print("diagnosing the recording ...", file=sys.stderr)
            dg = diagnose(data_from_recording(rec))
    except (RecordingError, OSError, ValueError, KeyError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        rep = design(dg, args, args.out, str(path), notes, plots=not args.no_plots)
    except ValueError as exc:  # e.g. nothing to design for
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"next excitation: {rep['excitation']} ({rep['duration_s']:g} s)")
    print(f"written: {args.out}/next_excitation.json, {args.out}/design.md")
    return 0
