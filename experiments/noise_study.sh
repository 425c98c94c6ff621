#!/usr/bin/env bash
# Issue 18's study (docs/noise.md "Which robust mode", docs/results.md): the pilot that
# chooses the robust noise mode, then Table 3 under the paper's protocol (noise=fixed) and
# under the chosen mode (noise=information), every run scored on 32 held-out seeds.
#
#   experiments/noise_study.sh [SEEDS] [STEPS]
#
#   SEEDS  Table 3 seeds (default 10: first every step at 5 seeds, then 5..SEEDS-1)
#   STEPS  in order, of "pilot ablation eas more schemes bo" (default all):
#          pilot    = MGSAEA-IPC (experiment=results: RBF, 697 evaluations), seeds 0-3,
#                     noise fixed / average K=2 / average K=4 / information
#          ablation = MGSAEA, MGSAEA*, MGSAEA-IPC, seeds 0-4, both modes
#          eas      = the six evolutionary baselines, seeds 0-4, both modes
#          more     = the nine algorithms, seeds 5..SEEDS-1, both modes
#          schemes  = Figs. 8-9 (schemes A/B/C x k = 1..5, one seed), both modes
#          bo       = qLogNEHVI, seeds 0..SEEDS-1, both modes (hours per run: last)
#
# Each step is an experiments/run_paper_sweeps.sh call (results preset) or a plain sweep;
# re-running the script skips finished runs and resumes unfinished ones. Environment as
# for run_paper_sweeps.sh (N_JOBS, LAUNCHER, PY). Robust mode: ROBUST (default information).
set -euo pipefail
cd "$(dirname "$0")/.."
SEEDS=${1:-10}
STEPS=${2:-"pilot ablation eas more schemes bo"}
ROBUST=${ROBUST:-information}
N_JOBS=${N_JOBS:-2}
export NUMBA_NUM_THREADS=${NUMBA_NUM_THREADS:-1} N_JOBS
PY=${PY:-.venv/bin/python}
ABLATION=mgsaea,mgsaea_star,mgsaea_ipc
EAS=nsga2,nsga3,cmoead,ctsea,ssde,cmoes
SWEEPS=experiments/run_paper_sweeps.sh

table3() {  # algorithms, seeds (0..n-1; finished runs are skipped)
  local mode
  for mode in fixed "$ROBUST"; do
    NOISE=$mode ALGORITHMS=$1 $SWEEPS results "$2" 1 table3 || true
  done
}

for step in $STEPS; do
  echo "== noise study step $step ($(date -u +%FT%TZ))" >&2
  case $step in
    pilot)
      launcher=(hydra/launcher=local_parallel "hydra.launcher.n_jobs=$N_JOBS")
      "$PY" -m tmopt -m experiment=results name=pilot_noise problem.noise=fixed,information \
        'seed=range(0,4)' "${launcher[@]}" || true
      "$PY" -m tmopt -m experiment=results name=pilot_noise problem.noise=average \
        problem.noise_samples=4,2 'seed=range(0,4)' "${launcher[@]}" || true
      "$PY" -m tmopt.collect multirun/pilot_noise ;;
    ablation) table3 "$ABLATION" 5 ;;
    eas) table3 "$EAS" 5 ;;
    more) table3 "$ABLATION,$EAS" "$SEEDS" ;;
    schemes)
      for mode in fixed "$ROBUST"; do
        NOISE=$mode $SWEEPS results 5 1 schemes || true
      done ;;
    bo)
      for mode in fixed "$ROBUST"; do
        NOISE=$mode $SWEEPS results "$SEEDS" 1 table3_bo || true
      done ;;
    *) echo "unknown step $step (use pilot, ablation, eas, more, schemes, bo)" >&2; exit 2 ;;
  esac
done
