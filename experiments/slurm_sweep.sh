#!/usr/bin/env bash
# A real tmopt sweep through SLURM with one job cancelled and resumed, compared with the
# same sweep through Hydra's basic launcher (experiments/slurm_sweep.py says what it does).
#
#   sudo experiments/slurm_local.sh up      # a one-node cluster on this machine (or use yours)
#   experiments/slurm_sweep.sh --quick      # ends: slurm: jobs=12 completed=12 ...
#   sudo experiments/slurm_local.sh down
#
# --time-limit: also a run past its SLURM time limit, requeued and resumed (~4 min).
# Other options: --budget N --seeds N --out DIR --timeout-min N (--help).
# Uses the repository's .venv when there is one, else python3.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-}
if [[ -z $PY ]]; then
  if [[ -x .venv/bin/python ]]; then PY=.venv/bin/python; else PY=python3; fi
fi
exec "$PY" experiments/slurm_sweep.py "$@"
