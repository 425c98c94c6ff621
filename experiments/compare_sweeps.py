"""Two sweeps side by side, setting by setting (e.g. the same algorithms, RBF vs GP):

    python experiments/compare_sweeps.py multirun/benchmarks multirun/benchmarks_gp \
        --keys problem,algorithm,budget --labels rbf,gp

Prints a Markdown table: for every setting of ``--keys`` with complete runs in both
sweeps, IGD and HV mean ± std over seeds in each and the two-sided Wilcoxon rank-sum
p-value of the second against the first (tmopt.reporting.compare).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tmopt.reporting.compare import compare_sweeps


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("sweep_a", type=Path)
    ap.add_argument("sweep_b", type=Path)
    ap.add_argument("--keys", default="problem,algorithm,budget",
                    help="comma list of setting keys that runs are matched on")
    ap.add_argument("--labels", default="A,B", help="names of the two sweeps, comma list")
    args = ap.parse_args(argv)
    labels = args.labels.split(",")
    if len(labels) != 2:
        ap.error(f"--labels must be two names separated by a comma, got {args.labels!r}")
    try:
        print(compare_sweeps(args.sweep_a, args.sweep_b, args.keys.split(","),
                             (labels[0], labels[1])), end="")
    except (FileNotFoundError, ValueError) as err:
        ap.error(str(err))
    return 0


if __name__ == "__main__":
    sys.exit(main())
