"""The sample-rate rule: one physics at every rate (tmopt.physics.scenario.config_at_rate).

    python experiments/sample_rate_rule.py [--seeds 20] [--rates 5 10 20 40]

Fig. 6 motion (x1 = 5e-5 sin(2 pi t/300), x2 = 3e-5 sin(2 pi t/500), 1200 s, FRBF-PID),
k1xx identified by RLS, on two configurations per sample rate fs:

* ``rule`` -- ``config_at_rate(fs)``: Table 1 noise ASDs and the continuous PID gains of
  the 10 Hz design (what the stiffness problem, the generator and ``python -m
  tmopt.simulate`` use);
* ``per-sample`` -- ``SimulationConfig(sample_rate=fs)``: the 10 Hz per-sample sigmas and
  gains kept as numbers (the stiffness problem's route before issue 21): a lower noise ASD
  above 10 Hz, a higher one below, and other continuous gains.

Expectation: the continuous system and the noise ASDs are the same under the rule, so the
identification error (a least-squares average over the run, Eqs. 10-16) should depend
little on fs; on the per-sample route the error scales roughly with the noise ASD,
``sqrt(10 Hz / fs)``.  Prints median and interquartile range over ``--seeds`` noise draws
of convergence accuracy (Eq. 19), final accuracy and M (Eq. 29).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from tmopt.physics.excitation import MultiSine
from tmopt.physics.objectives import evaluate
from tmopt.physics.scenario import MIN_SAMPLE_RATE, config_at_rate
from tmopt.physics.simulator import SimulationConfig, simulate

REF1 = MultiSine(5e-5, 2 * math.pi / 300)
REF2 = MultiSine(3e-5, 2 * math.pi / 500)
KEYS = ("convergence_accuracy", "final_accuracy", "M")


def numbers(cfg: SimulationConfig, seeds: int) -> dict[str, np.ndarray]:
    """Eq. 19 accuracy, final accuracy and M of k1xx for noise seeds 0..seeds-1."""
    out: dict[str, list[float]] = {k: [] for k in KEYS}
    for seed in range(seeds):
        ev = evaluate(simulate(REF1, REF2, cfg, seed=seed), idx=0)
        for k in KEYS:
            out[k].append(float(ev[k][0]))
    return {k: np.array(v) for k, v in out.items()}


def cell(v: np.ndarray) -> str:
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return f"{med:.3g} [{q1:.3g}, {q3:.3g}]"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--rates", type=float, nargs="+", default=[5.0, 10.0, 20.0, 40.0])
    args = p.parse_args()
    if args.seeds < 1 or min(args.rates) < MIN_SAMPLE_RATE:
        raise SystemExit(f"--seeds must be >= 1 and --rates in [{MIN_SAMPLE_RATE:g}, inf) Hz")
    print(f"k1xx, Fig. 6 motion, 1200 s, FRBF-PID; median [IQR] over {args.seeds} noise seeds")
    print("| fs [Hz] | route | " + " | ".join(KEYS) + " |")
    print("|---|---|" + "---|" * len(KEYS))
    for fs in args.rates:
        routes = {"rule": config_at_rate(fs, record="estimates"),
                  "per-sample": SimulationConfig(sample_rate=fs, record="estimates")}
        for name, cfg in routes.items():
            got = numbers(cfg, args.seeds)
            print(f"| {fs:g} | {name} | " + " | ".join(cell(got[k]) for k in KEYS) + " |")


if __name__ == "__main__":
    main()
