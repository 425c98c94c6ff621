"""Small helpers shared by the paper-reproduction scripts in experiments/."""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from tmopt.physics.excitation import PERIOD_BOUNDS, MultiSine
from tmopt.physics.simulator import SimulationConfig

__all__ = ["output_dir", "write_csv", "write_rows", "seed_stats", "fmt_stats",
           "feasible_population", "study_designs", "FIG6_REFERENCES"]  # fmt: skip

#: Sec. 4.3's fixed motion state (Fig. 6): x1 = 5e-5 sin(2 pi t/300), x2 = 3e-5 sin(2 pi t/500).
FIG6_REFERENCES = ((5e-5, 2 * np.pi / 300), (3e-5, 2 * np.pi / 500))


def output_dir(name: str, override: str | None = None) -> Path:
    """``experiments/out/<name>/`` (git-ignored) unless ``override`` is given; created."""
    root = Path(__file__).resolve().parents[2] / "experiments" / "out" / name
    path = Path(override) if override else root
    path.mkdir(parents=True, exist_ok=True)
    return path


def write_csv(path: Path, columns: Mapping[str, np.ndarray]) -> None:
    """Equal-length 1-D columns -> CSV with a header row (full float precision)."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n]) for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")


def write_rows(path: Path, rows: Sequence[Mapping[str, object]]) -> None:
    """List of dicts (same keys) -> CSV."""
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def seed_stats(values: Sequence[float]) -> dict[str, float]:
    """Median, min and max over noise seeds (the spread every reported number carries)."""
    v = np.asarray(values, dtype=float)
    return {"median": float(np.median(v)), "min": float(v.min()), "max": float(v.max()),
            "n": int(v.size)}  # fmt: skip


def fmt_stats(values: Sequence[float], fmt: str = ".3g") -> str:
    """``median (min-max)`` of ``values``."""
    s = seed_stats(values)
    return f"{s['median']:{fmt}} ({s['min']:{fmt}}-{s['max']:{fmt}})"


def feasible_population(
    n: int, k: int, seed: int, accel_limit: float = 5e-8, motion_limit: float = 4e-4,
    periods: tuple[float, float] = PERIOD_BOUNDS, amplitude_max: float = 2e-4,
    duration: float = SimulationConfig.duration,
    sample_rate: float = SimulationConfig.sample_rate,
) -> MultiSine:
    """``n`` k-frequency references that satisfy Eq. 20 *a priori* (on the reference).

    Periods log-uniform in ``periods``, phases uniform in [0, 2 pi); each amplitude takes a
    Dirichlet share of a budget ``s alpha1 F_max`` of ``sum_i A_i w_i^2`` (``s`` uniform in
    [0.2, 1]), capped at ``amplitude_max``; draws whose ``max |x_ref|`` exceeds
    ``motion_limit`` are redrawn.  Uniform draws of the problem's box are almost never
    feasible at k = 3 (docs/decisions.md), so studies of feasible designs use these.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * sample_rate))) / sample_rate
    out_a, out_w, out_p = [], [], []
    while len(out_a) < n:
        w = 2 * np.pi / np.exp(rng.uniform(*np.log(periods), k))
        share = rng.dirichlet(np.ones(k)) * rng.uniform(0.2, 1.0) * accel_limit
        a = np.minimum(share / w**2, amplitude_max)
        ph = rng.uniform(0, 2 * np.pi, k)
        ref = MultiSine(a, w, ph)
        if ref.max_accel()[0] <= accel_limit and np.abs(ref.evaluate(t)).max() <= motion_limit:
            out_a.append(a)
            out_w.append(w)
            out_p.append(ph)
    return MultiSine(np.array(out_a), np.array(out_w), np.array(out_p))


def study_designs(n: int, k: int = 3) -> tuple[MultiSine, MultiSine]:
    """The Fig. 6 state (design 0) then ``n`` a-priori feasible k-frequency pairs (TM1 from
    population seed 1, TM2 from seed 2): the design set of the physics studies."""
    pops = (feasible_population(n, k, seed=1), feasible_population(n, k, seed=2))
    out = []
    for (a0, w0), pop in zip(FIG6_REFERENCES, pops):
        first = np.zeros((1, k))
        amp, omega = first.copy(), first.copy()
        amp[0, 0], omega[0, 0] = a0, w0
        out.append(MultiSine(np.vstack([amp, pop.amplitude]), np.vstack([omega, pop.omega]),
                             np.vstack([first, pop.phase])))  # fmt: skip
    return out[0], out[1]
