#!/usr/bin/env bash
# Issue 18's study (docs/noise.md "Which robust mode", docs/results.md): the pilot that
# chooses the robust noise mode, then Table 3 under the paper's protocol (noise=fixed) and
# under the chosen mode (noise=information), every run scored on 32 held-out seeds.
#
#   experiments/noise_study.sh [SEEDS] [STEPS]
#
#   SEEDS  Table 3 seeds 0..SEEDS-1 (default 10)
#   STEPS  in order, of "pilot ablation eas more schemes bo" (default all):
#          pilot    = MGSAEA-IPC (experiment=results: RBF, 697 evaluations), seeds 0-3,
#                     noise fixed / information / average K=4 / average K=2
#                     (multirun/pilot_noise)
#          ablation = MGSAEA and MGSAEA*, seeds 0-3, then the three MGSAEA variants at
#                     seed 4, both modes
#          eas      = the six evolutionary baselines, seeds 0-4, both modes
#          more     = the nine algorithms, seeds 5..SEEDS-1, both modes
#          schemes  = Figs. 8-9 (schemes A/B/C x k = 1..5, one seed), both modes
#          bo       = qLogNEHVI, seeds 0..SEEDS-1, both modes (hours per run: last)
#
# Table 3 folders: multirun/results_table3 (fixed) and multirun/results_<ROBUST>_table3, the
# names and overrides of experiments/run_paper_sweeps.sh (which resumes them too). Seed by
# seed (both modes, then the next seed), so a stopped study leaves paired seeds. MGSAEA-IPC's
# seeds 0-3 are the pilot's runs (the same configuration): collect the folders together,
#   python -m tmopt.collect multirun/results_table3 multirun/results_information_table3 \
#     multirun/pilot_noise --out multirun/table3_noise
# Re-running the script skips finished runs and resumes unfinished ones. Environment:
# N_JOBS (2), PY, ROBUST (information).
set -euo pipefail
cd "$(dirname "$0")/.."
SEEDS=${1:-10}
STEPS=${2:-"pilot ablation eas more schemes bo"}
ROBUST=${ROBUST:-information}
N_JOBS=${N_JOBS:-2}
export NUMBA_NUM_THREADS=${NUMBA_NUM_THREADS:-1} N_JOBS
PY=${PY:-.venv/bin/python}
EAS=nsga2,nsga3,cmoead,ctsea,ssde,cmoes
launcher=(hydra/launcher=local_parallel "hydra.launcher.n_jobs=$N_JOBS")

table3() {  # algorithms, seed: one sweep per noise mode into run_paper_sweeps.sh's folders
  local mode tag
  for mode in fixed "$ROBUST"; do
    tag=results; [[ $mode != fixed ]] && tag=results_$mode
    echo "== $(date -u +%T) table3 noise=$mode algorithm=$1 seed=$2" >&2
    "$PY" -m tmopt -m experiment=results "name=${tag}_table3" "problem.noise=$mode" \
      "algorithm=$1" "seed=$2" "${launcher[@]}" || echo "!! sweep ended with an error" >&2
  done
}

for step in $STEPS; do
  echo "== noise study step $step ($(date -u +%FT%TZ))" >&2
  case $step in
    pilot)
      "$PY" -m tmopt -m experiment=results name=pilot_noise problem.noise=fixed,information \
        'seed=range(0,4)' "${launcher[@]}" || true
      "$PY" -m tmopt -m experiment=results name=pilot_noise problem.noise=average \
        problem.noise_samples=4,2 'seed=range(0,4)' "${launcher[@]}" || true
      "$PY" -m tmopt.collect multirun/pilot_noise ;;
    ablation)
      for s in 0 1 2 3; do table3 mgsaea,mgsaea_star "$s"; done
      table3 mgsaea,mgsaea_star,mgsaea_ipc 4 ;;
    eas) for s in 0 1 2 3 4; do table3 "$EAS" "$s"; done ;;
    more)
      for ((s = 5; s < SEEDS; s++)); do
        table3 "mgsaea,mgsaea_star,mgsaea_ipc,$EAS" "$s"
      done ;;
    schemes)
      for mode in fixed "$ROBUST"; do
        NOISE=$mode experiments/run_paper_sweeps.sh results 5 1 schemes || true
      done ;;
    bo)
      for mode in fixed "$ROBUST"; do
        NOISE=$mode experiments/run_paper_sweeps.sh results "$SEEDS" 1 table3_bo || true
      done ;;
    *) echo "unknown step $step (use pilot, ablation, eas, more, schemes, bo)" >&2; exit 2 ;;
  esac
done
