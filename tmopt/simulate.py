"""``python -m tmopt.simulate``: one closed-loop stiffness-identification run, on the command line.

Simulates the two test masses following a reference motion (the paper's Fig. 6 motion
by default, or any excitation spec), prints the identification numbers of k1xx and k2xx
(Eqs. 18, 19, 29 and the final error), and writes the run as a recording in the
standard format (docs/recording-format.md) plus a plot of the motion and the
identification curves. The recording can go straight into ``python -m tmopt.mismatch``.

Excitation specs, settings and the sample-rate rule are the scenario's
(:mod:`tmopt.physics.scenario`), shared with the recording generator and the stiffness
problem, so a simulation here and a clean control there are the same run.  This command
is physics only: it imports nothing of the mismatch tool.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tmopt.physics import objectives
from tmopt.physics.geometry import Geometry
from tmopt.physics.recording import recording_from_simulation, write_recording
from tmopt.physics.scenario import Settings, excitation, simulation_config
from tmopt.physics.simulator import SimulationResult, simulate

PARAMETERS = {"k1xx": 0, "k2xx": 1}


def run(settings: Settings, seed: int = 0) -> SimulationResult:
    """Simulate ``settings`` (excitation, duration, rate, noise, controller, truths)."""
    ref1, ref2, _ = excitation(settings.excitation, settings.duration, settings.sample_rate)
    cfg = simulation_config(settings, Geometry())
    return simulate(ref1[None], ref2[None], cfg, seed=seed)


def summary(result: SimulationResult, eps: float = 1e-10) -> dict[str, dict[str, float]]:
    """Eqs. 18, 19, 29 and the final error for k1xx and k2xx."""
    out = {}
    for name, idx in PARAMETERS.items():
        obj = objectives.evaluate(result, idx=idx, eps=eps)
        out[name] = {k: float(obj[k][0]) for k in ("convergence_time", "convergence_accuracy",
                                                   "final_accuracy", "M")}
    return out


def table(result: SimulationResult, numbers: dict) -> str:
    rows = ["| quantity | k1xx | k2xx |", "|---|---|---|"]
    for key, unit in (("convergence_time", "s"), ("convergence_accuracy", "s^-2"),
                      ("final_accuracy", "s^-2"), ("M", "")):
        rows.append(f"| {key} {unit} | {numbers['k1xx'][key]:.4g} | {numbers['k2xx'][key]:.4g} |")
    err = result.max_tracking_error[0]
    steady = result.steady_tracking_error[0]
    rows.append(f"| max tracking error TM1 / TM2 m | {err[0]:.3g} | {err[1]:.3g} |")
    rows.append(f"| steady tracking error TM1 / TM2 m | {steady[0]:.3g} | {steady[1]:.3g} |")
    if result.diverged[0]:
        rows.append(f"\nthe closed loop diverged: {result.reason[0]}")
    return "\n".join(rows)


def plot(result: SimulationResult, path: Path) -> None:
    """Reference and controlled motion of both test masses, and the identification curves."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = result.time
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for ax, tm in zip(axes[:2], (1, 2)):
        ax.plot(t, getattr(result, f"ref_x{tm}")[0], label="reference", lw=1)
        ax.plot(t, getattr(result, f"x{tm}")[0], "--", label="controlled (measured)", lw=1)
        ax.set_ylabel(f"x{tm} [m]")
        ax.legend(fontsize=8)
    for name, idx in PARAMETERS.items():
        axes[2].plot(t, result.theta_hat[0, :, idx], label=name)
        axes[2].axhline(result.config.theta_true[idx], color="0.6", lw=0.8)
    truth = result.config.theta_true[:2]
    span = max(float(np.max(np.abs(truth))), 1e-9)
    axes[2].set_ylim(truth.min() - span, truth.max() + span)  # the start-up transient is huge
    axes[2].set_ylabel("RLS estimate [s^-2]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _parser() -> argparse.ArgumentParser:
    d = Settings()
    p = argparse.ArgumentParser(prog="python -m tmopt.simulate", description=__doc__.split(
        "\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="excitation specs: paper | multisine:A@P[@phase],...;A@P,... | "
               "chirp:A,f0,f1;A,f0,f1 | steps:A,hold[,ramp];... | none")
    p.add_argument("--excitation", default=d.excitation, help="reference motion spec")
    p.add_argument("--duration", type=float, default=d.duration, help="seconds")
    p.add_argument("--sample-rate", type=float, default=d.sample_rate, help="Hz")
    p.add_argument("--controller", default=d.controller, choices=["frbf_pid", "pid"])
    p.add_argument("--noise-scale", type=float, default=d.noise_scale,
                   help="multiplies every Table 1 noise")
    p.add_argument("--seed", type=int, default=0, help="noise realisation")
    p.add_argument("--out", default="simulation.h5",
                   help="recording to write (.h5 or .csv + .json sidecar); a PNG goes beside it")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        settings = Settings(duration=args.duration, sample_rate=args.sample_rate,
                            excitation=args.excitation, noise_scale=args.noise_scale,
                            controller=args.controller,
                            description=f"tmopt.simulate {args.excitation}")
        if args.seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {args.seed}")
        result = run(settings, seed=args.seed)
    except ValueError as exc:
        print(f"tmopt.simulate: error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_recording(recording_from_simulation(result, 0, description=settings.description), out)
    plot(result, out.with_suffix(".png"))
    print(table(result, summary(result)))
    print(f"\nrecording: {out}\nplot: {out.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
