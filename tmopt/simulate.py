"""``python -m tmopt.simulate``: one closed-loop stiffness-identification run, on the command line.

Simulates the two test masses following a reference motion (the paper's Fig. 6 motion
by default, or any excitation spec), prints the identification numbers of k1xx and k2xx
(Eqs. 18, 19, 29 and the final error), the realised motion and force of each test mass
with Eq. 20's constraints on them, and writes the run as a recording in the standard
format (docs/recording-format.md) plus a plot of the motion and the identification
curves; ``--json FILE`` writes every printed number, per test mass. The recording can go
straight into ``python -m tmopt.mismatch``.

Excitation specs, settings (the physics options ``--ramp-in``, ``--rls-columns``,
``--y-axes``, ``--jacobian`` included) and the sample-rate rule are the scenario's
(:mod:`tmopt.physics.scenario`), shared with the recording generator and the stiffness
problem, so a simulation here and a clean control there are the same run but for the
spacecraft acceleration every generated recording carries
(``tmopt.mismatch.generate.SPACECRAFT_ACCELERATION``).  This command is physics only: it
imports nothing of the mismatch tool.
"""

from __future__ import annotations

import argparse
import json
import sys
import types
from collections.abc import Sequence
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

from tmopt.physics import objectives
from tmopt.physics.control import JACOBIANS
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import (
    RecordingError,
    recording_format,
    recording_from_simulation,
    write_recording,
)
from tmopt.physics.scenario import Y_AXES, Settings, excitation_axes, simulation_config
from tmopt.physics.simulator import RLS_COLUMN_SETS, SimulationConfig, SimulationResult, simulate

PARAMETERS = {"k1xx": 0, "k2xx": 1}
#: Rows of the printed table and keys of the JSON, per test mass: (key, unit, format).
ROWS = (("convergence_time", "s", ".4g"), ("convergence_accuracy", "s^-2", ".4g"),
        ("final_accuracy", "s^-2", ".4g"), ("M", "", ".4g"),
        ("max_abs_x", "m", ".4g"), ("max_abs_force", "m s^-2", ".4g"),
        ("max_tracking_error", "m", ".3g"), ("steady_tracking_error", "m", ".3g"),
        ("eq20_force", "", ".3f"), ("eq20_motion", "", ".3f"))  # fmt: skip


def config(settings: Settings) -> SimulationConfig:
    """The simulator's configuration of ``settings``: the scenario's
    (:func:`tmopt.physics.scenario.simulation_config`), nominal geometry."""
    return simulation_config(settings, Geometry())


def run(settings: Settings | None = None, seed: int = 0, **options: Any) -> SimulationResult:
    """Simulate ``settings`` (excitation, duration, rate, noise, controller, truths and the
    physics options ``ramp_in``, ``rls_columns``, ``y_axes``, ``jacobian``; None: the
    paper's defaults); ``options`` replace fields of ``settings``. The excitation may also
    set y set points (``multisine:x1;x2;y1;y2``), which the y loops track.

    This is also what ``tmopt.simulate(...)`` calls: the module is callable (below), so
    ``from tmopt import simulate; result = simulate(duration=60, seed=1)`` works beside
    ``python -m tmopt.simulate``.
    """
    settings = replace(Settings() if settings is None else settings, **options)
    refs, _ = excitation_axes(settings.excitation, settings.duration, settings.sample_rate)
    ref_y = (refs[2][None], refs[3][None]) if np.any(refs[2:]) else None
    return simulate(refs[0][None], refs[1][None], config(settings), seed=seed, ref_y=ref_y)


def summary(
    result: SimulationResult, eps: float = objectives.EPSILON
) -> dict[str, dict[str, float]]:
    """Per test mass: Eqs. 18, 19, 29 and the final error of its sensitive-axis stiffness,
    and the realised run -- largest displacement and commanded force, tracking errors and
    Eq. 20 on them (``eq20_*`` = value / limit - 1, feasible <= 0)."""
    cfg = result.config
    g = objectives.eq20_realised(result)[0]
    out = {}
    for tm, (name, idx) in enumerate(PARAMETERS.items()):
        obj = objectives.evaluate(result, idx=idx, eps=eps)
        row = {"parameter": name}
        row.update({k: float(obj[k][0]) for k in ("convergence_time", "convergence_accuracy",
                                                  "final_accuracy", "M")})  # fmt: skip
        row["max_abs_x"] = float(result.max_abs_position[0, tm])
        row["max_abs_force"] = float(result.max_abs_command[0, tm])
        row["max_tracking_error"] = float(result.max_tracking_error[0, tm])
        row["steady_tracking_error"] = float(result.steady_tracking_error[0, tm])
        row["eq20_force"] = float(g[2 * tm] / (cfg.alpha1 * cfg.f_max))
        row["eq20_motion"] = float(g[2 * tm + 1] / (cfg.alpha2 * cfg.gap))
        row["eq20"] = {"force": row["eq20_force"], "motion": row["eq20_motion"],
                       "force_limit": cfg.alpha1 * cfg.f_max,
                       "motion_limit": cfg.alpha2 * cfg.gap,
                       "satisfied": bool(max(g[2 * tm], g[2 * tm + 1]) <= 0)}  # fmt: skip
        out[f"TM{tm + 1}"] = row
    return out


def table(result: SimulationResult, numbers: dict) -> str:
    rows = ["| quantity | TM1 (k1xx) | TM2 (k2xx) |", "|---|---|---|"]
    for key, unit, fmt in ROWS:
        a, b = numbers["TM1"][key], numbers["TM2"][key]
        rows.append(f"| {key} {unit} | {a:{fmt}} | {b:{fmt}} |")
    rows.append(f"| Eq. 20 satisfied | {numbers['TM1']['eq20']['satisfied']} | "
                f"{numbers['TM2']['eq20']['satisfied']} |")  # fmt: skip
    if result.diverged[0]:
        rows.append(f"\nthe closed loop diverged: {result.reason[0]}")
    return "\n".join(rows)


def json_report(result: SimulationResult, numbers: dict, settings: Settings, seed: int,
                files: dict[str, str]) -> dict:  # fmt: skip
    """Everything the command prints, plus the settings that produced it."""
    cfg = result.config
    return {
        "settings": {**asdict(settings), "seed": seed, "controller": cfg.controller,
                     "ramp_in": cfg.ramp_in, "rls_columns": list(cfg.rls_columns),
                     "jacobian": cfg.control.jacobian, "fb_bias": list(cfg.fb_bias),
                     "fb_sigma": cfg.fb_sigma, "y_gains": list(cfg.control.y_gains),
                     "y_derivative_filter": cfg.control.y_derivative_filter},
        **numbers,
        "diverged": bool(result.diverged[0]),
        "reason": result.reason[0] or None,
        **files,
    }  # fmt: skip


def plot(result: SimulationResult, path: Path) -> None:
    """Reference and controlled motion of both test masses, and the identification curves."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = result.time
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for ax, tm in zip(axes[:2], (1, 2)):
        ref = getattr(result, f"ref_x{tm}")[0]
        ax.plot(t, ref, label="reference", lw=1)
        ax.plot(t, getattr(result, f"x{tm}")[0], "--", label="controlled (measured)", lw=1)
        ax.set_ylabel(f"TM{tm} sensitive axis x{tm} [m]")
        # reference and motion overlap at this scale: the tracking error on its own axis
        err = ax.twinx()
        err.plot(t, ref - getattr(result, f"x{tm}_true")[0], color="0.5", lw=0.6,
                 label="tracking error r - x (true)")
        err.set_ylabel("tracking error [m]", color="0.4")
        lines = ax.get_legend_handles_labels(), err.get_legend_handles_labels()
        ax.legend(lines[0][0] + lines[1][0], lines[0][1] + lines[1][1], fontsize=7,
                  loc="upper right")
    for name, idx in PARAMETERS.items():
        axes[2].plot(t, result.theta_hat[0, :, idx], label=f"{name} estimate (RLS)")
        axes[2].axhline(result.config.theta_true[idx], color="0.4", lw=0.8, ls=":",
                        label=f"{name} truth")
    truth = result.config.theta_true[:2]
    span = max(float(np.max(np.abs(truth))), 1e-9)
    axes[2].set_ylim(truth.min() - span, truth.max() + span)  # the start-up transient is huge
    axes[2].set_ylabel("stiffness [s$^{-2}$]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _parser() -> argparse.ArgumentParser:
    d = Settings()
    p = argparse.ArgumentParser(prog="python -m tmopt.simulate", description=__doc__.split(
        "\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="excitation specs: paper | multisine:A@P[@phase],...;A@P,...[;y1 parts;y2 parts] | "
               "chirp:A,f0,f1;A,f0,f1 | steps:A,hold[,ramp];... | none")
    p.add_argument("--excitation", default=d.excitation, help="reference motion spec")
    p.add_argument("--duration", type=float, default=d.duration, help="seconds")
    p.add_argument("--sample-rate", type=float, default=d.sample_rate, help="Hz")
    p.add_argument("--controller", default=d.controller, choices=["frbf_pid", "pid"])
    p.add_argument("--noise-scale", type=float, default=d.noise_scale,
                   help="multiplies every Table 1 noise")
    p.add_argument("--seed", type=int, default=0, help="noise realisation")
    p.add_argument("--ramp-in", type=float, default=d.ramp_in,
                   help="seconds over which the references ramp in (0: none)")
    p.add_argument("--rls-columns", default=d.rls_columns, choices=sorted(RLS_COLUMN_SETS),
                   help="theta columns the RLS identifies")
    p.add_argument("--y-axes", default=d.y_axes, choices=sorted(Y_AXES),
                   help="non-sensitive axes and spacecraft acceleration setting")
    p.add_argument("--jacobian", default=d.jacobian, choices=list(JACOBIANS),
                   help="plant-Jacobian sign of the FRBF-PID's learning law")
    p.add_argument("--out", default="simulation.h5",
                   help="recording to write (.h5 or .csv + .json sidecar); a PNG goes beside it")
    p.add_argument("--json", default=None, metavar="FILE",
                   help="also write every printed number (per test mass) to this JSON file")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        settings = Settings(duration=args.duration, sample_rate=args.sample_rate,
                            excitation=args.excitation, noise_scale=args.noise_scale,
                            controller=args.controller, ramp_in=args.ramp_in,
                            rls_columns=args.rls_columns, y_axes=args.y_axes,
                            jacobian=args.jacobian,
                            description=f"tmopt.simulate {args.excitation}")
        if args.seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {args.seed}")
        try:
            recording_format(args.out)
        except RecordingError as exc:
            raise ValueError(f"--out {exc}") from None
        result = run(settings, seed=args.seed)
    except ValueError as exc:
        print(f"tmopt.simulate: error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_recording(recording_from_simulation(result, 0, description=settings.description), out)
    plot(result, out.with_suffix(".png"))
    numbers = summary(result)
    print(table(result, numbers))
    files = {"recording": str(out), "plot": str(out.with_suffix(".png"))}
    print(f"\nrecording: {out}\nplot: {out.with_suffix('.png')}")
    if args.json:
        path = Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(json_report(result, numbers, settings, args.seed, files),
                                   indent=2) + "\n")  # fmt: skip
        print(f"json: {path}")
    return 0


class _CallableModule(types.ModuleType):
    """``tmopt.simulate`` is both this module and the function :func:`run`."""

    def __call__(self, settings: Settings | None = None, seed: int = 0,
                 **options: Any) -> SimulationResult:
        return run(settings, seed, **options)


sys.modules[__name__].__class__ = _CallableModule

if __name__ == "__main__":
    sys.exit(main())
