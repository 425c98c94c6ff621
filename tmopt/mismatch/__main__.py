"""``python -m tmopt.mismatch RECORDING --out DIR``: locate, explain and model a mismatch
between the nominal model (Eqs. 9-16) and a recording (HDF5, or CSV + JSON sidecar)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tmopt.design.cli import add_design_options, check_design_options
from tmopt.mismatch.calibration import FAMILY_ALPHA, LOCATE_ALPHA
from tmopt.mismatch.diagnose import RAILS, Settings, diagnose
from tmopt.mismatch.fit import data_from_recording
from tmopt.mismatch.generic import LINE_REFINE, TIMING_DEFAULT, TIMING_REGRESSORS
from tmopt.mismatch.report import write_report
from tmopt.physics.recording import RecordingError, read_recording


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m tmopt.mismatch", description=__doc__)
    p.add_argument("recording", help="recording file (.h5/.hdf5, or .csv with its .json)")
    p.add_argument("--out", required=True, help="output folder (report.md/json, PNGs)")
    p.add_argument("--alpha", type=float, default=FAMILY_ALPHA,
                   help=f"family-wise level of the catalogue test (default {FAMILY_ALPHA}, "
                        "calibrated)")  # fmt: skip
    p.add_argument("--locate-alpha", type=float, default=LOCATE_ALPHA,
                   help=f"family-wise level of the locate step (default {LOCATE_ALPHA})")
    p.add_argument("--max-effects", type=int, default=4, help="most effects to add (4)")
    p.add_argument("--joint", action="store_true",
                   help="run the joint stage (re-tests under the alternative's noise model; "
                        "off by default, docs/mismatch.md 9.9)")  # fmt: skip
    p.add_argument("--no-rejudge", action="store_true",
                   help="do not judge a weak name again under the alternative's noise model "
                        "(on by default, docs/mismatch.md 9.16)")  # fmt: skip
    p.add_argument("--no-in-place", action="store_true",
                   help="keep every near alternative as a rival, even one the data still need "
                        "the effect beside (on by default, docs/mismatch.md 9.16)")  # fmt: skip
    p.add_argument("--no-shape-search", action="store_true",
                   help="check a drift's shape with Legendre P2 + P3 only, not also the "
                        "searched step and relaxation on its axis (on by default, "
                        "docs/mismatch.md 9.17)")  # fmt: skip
    p.add_argument("--no-shape-placements", action="store_true",
                   help="check a drift's shape at its named channel only, not also with the "
                        "drift moved to each near same-name alternative's channel (on by "
                        "default, docs/mismatch.md 9.18)")  # fmt: skip
    p.add_argument("--no-pairs", action="store_true",
                   help="do not test candidates in pairs where no single one is significant "
                        "(on by default, docs/mismatch.md 9.18)")  # fmt: skip
    p.add_argument("--no-true-position", action="store_true",
                   help="put the stiffness on the readout as recorded, not on the true "
                        "position with the readout noise taken out (on by default, "
                        "docs/mismatch.md 9.19)")  # fmt: skip
    p.add_argument("--kin-refit", action="store_true",
                   help="also read the kinematic group's candidates under the noise model "
                        "estimated with every kinematic column fitted (off by default: its "
                        "null is heavy-tailed where the tones sit in the record's lowest "
                        "bins; docs/mismatch.md 9.24)")  # fmt: skip
    p.add_argument("--kin-profile", action=argparse.BooleanOptionalAction, default=True,
                   help="read the kinematic group's candidates by their profile likelihood "
                        "ratio, the noise model estimated again under each (on by "
                        "default; docs/mismatch.md 9.29-9.31)")  # fmt: skip
    p.add_argument("--onset-profile", action="store_true",
                   help="judge a generic force step or relaxation's significance by its "
                        "profile likelihood ratio, the equation noise model estimated again "
                        "under it (off by default: it can out-rank a glitch; "
                        "docs/mismatch.md 9.30)")  # fmt: skip
    p.add_argument("--convention-profile", action=argparse.BooleanOptionalAction,
                   default=True,
                   help="where the Eq. 10 fit leaves the accelerometer's sampling "
                        "convention undecided, let the kinematic group's profile likelihood "
                        "decide when its lead is clear (on by default; docs/mismatch.md "
                        "9.32)")  # fmt: skip
    p.add_argument("--no-witness-refit", action="store_true",
                   help="read a witness-driven candidate (rotation coupling) under the "
                        "null's noise model only, not also under the alternative's (on by "
                        "default, docs/mismatch.md 9.28)")  # fmt: skip
    p.add_argument("--rails", choices=RAILS, default="fallback",
                   help="samples where a measured channel sits at its rail (an ADC "
                        "saturating): read as measurements, left out as gaps (mask), or "
                        "left out only when reading them refuses the recording (fallback, "
                        "the default; docs/mismatch.md 9.22)")  # fmt: skip
    p.add_argument("--timing-regressor", choices=TIMING_REGRESSORS, default=TIMING_DEFAULT,
                   help="the readout timing feature's regressor: the accelerometer term's "
                        "excitation-tone part (tones) or the measured term's derivative "
                        "below the excitation's band (band; docs/mismatch.md 9.34)")  # fmt: skip
    p.add_argument("--line-refine", action=argparse.BooleanOptionalAction, default=LINE_REFINE,
                   help="read a generic line's frequency off the whole record, not only the "
                        "longest gap-free segment's grid (on by default; docs/mismatch.md "
                        "9.38)")  # fmt: skip
    p.add_argument("--joint-correlation", action="store_true",
                   help="combine an accelerometer cross-talk's (or one-tap delay's) two "
                        "estimates with their correlation read from the recording (off by "
                        "default until its paired test; docs/mismatch.md 9.39)")  # fmt: skip
    p.add_argument("--line-profile", action="store_true",
                   help="judge a generic force line's significance by its profile "
                        "likelihood ratio (off by default: its null is not yet calibrated; "
                        "docs/mismatch.md 9.40)")  # fmt: skip
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--design-next", action="store_true",
                   help="also design the next excitation into --out (python -m tmopt.design)")
    add_design_options(p)
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if not (0 < args.alpha < 1 and 0 < args.locate_alpha < 1):
        print("error: --alpha and --locate-alpha must be in (0, 1)", file=sys.stderr)
        return 2
    if args.max_effects < 0:
        print("error: --max-effects must be >= 0", file=sys.stderr)
        return 2
    if args.design_next and check_design_options(args):
        print(f"error: {check_design_options(args)}", file=sys.stderr)
        return 2
    try:
        rec = read_recording(args.recording)
    except (RecordingError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    settings = Settings(alpha=args.alpha, locate_alpha=args.locate_alpha,
                        max_effects=args.max_effects, joint=args.joint,
                        rejudge=not args.no_rejudge, in_place=not args.no_in_place,
                        shape_search=not args.no_shape_search,
                        shape_placements=not args.no_shape_placements,
                        pairs=not args.no_pairs,
                        true_position=not args.no_true_position,
                        rails=args.rails, kin_refit=args.kin_refit,
                        kin_profile=args.kin_profile, onset_profile=args.onset_profile,
                        convention_profile=args.convention_profile,
                        witness_refit=not args.no_witness_refit,
                        timing_regressor=args.timing_regressor,
                        line_refine=args.line_refine,
                        joint_correlation=args.joint_correlation,
                        line_profile=args.line_profile)  # fmt: skip
    dg = diagnose(data_from_recording(rec), settings)
    rep = write_report(dg, args.out, plots=not args.no_plots)
    print(rep["conclusion"])
    out = Path(args.out)
    print(f"report: {out / 'report.md'}, {out / 'report.json'}")
    if args.design_next:
        from tmopt.design.cli import design

        try:
            nxt = design(dg, args, args.out, args.recording, plots=not args.no_plots)
        except ValueError as exc:  # nothing the recording left unidentified
            print(f"next excitation: none ({exc})")
            return 0
        print(f"next excitation: {nxt['excitation']} ({out / 'next_excitation.json'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
