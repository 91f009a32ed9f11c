#!/bin/bash
# Device calls of the terrain-curriculum runs on two nvidia-h200-x4 leases (each after the three chunk calls of
# pack.sh), kept as the record of what ran (RESULTS.md). The first call of each lease also installs (.dw3) and unpacks
# the precompiled kernel cache (precompile.py).
#
#   bash scripts/device/curriculum_runs.sh train     # lease 1: four curriculum runs from scratch, one per GPU
#   bash scripts/device/curriculum_runs.sh evaluate1 # lease 1: 1000-round evaluations of those runs
#   bash scripts/device/curriculum_runs.sh retrain   # lease 2: the same with a knee-lift floor, +- curriculum
#   bash scripts/device/curriculum_runs.sh evaluate  # lease 2: 1000-round evaluations (too many for 165 s: see README)
#   bash scripts/device/curriculum_runs.sh evaluate2 # lease 2: the rugged ones again, one per GPU
#   bash scripts/device/curriculum_runs.sh continue  # planned for lease 1 but not run: its results called for the
#                                             # retrain instead (resumes, or torchrun if complex_cur met 95 %)
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1
CUR="--levels 10 --start_levels 3 --seed 1"
MORE="--levels 10 --start_levels 10 --seed 2"   # a resumed run starts spread over every lane, not at the bottom
case "${1:-}" in
train)
  SKIP_WARMUP=1 DEADLINE_S=${DEADLINE_S:-540} bash scripts/device/train_runs.sh \
    "complex_cur@0:--terrain complex $CUR --target_success 0.95" \
    "complex_cur_dr@1:--terrain complex $CUR --randomize" \
    "rugged_cur@2:--terrain rugged $CUR" \
    "complex_cur8@3:--terrain complex $CUR --step_rise 0.08 --goal_distance 5.5"
  ;;
continue)
  train_s=${TRAIN_S:-300}
  if grep -q "stopped by target success" "$KEEP/complex_cur.log"; then   # time-to-skill on 2 GPUs
    first="complex_cur_2gpu@0,1:--terrain complex $CUR --target_success 0.95"
    second=""
  else
    first="complex_cur_b@0:--terrain complex $MORE --resume $KEEP/complex_cur.pt"
    second="complex_cur_dr_b@1:--terrain complex $MORE --randomize --resume $KEEP/complex_cur_dr.pt"
  fi
  SKIP_WARMUP=1 DEADLINE_S=$train_s bash scripts/device/train_runs.sh "$first" ${second:+"$second"} \
    "rugged_cur_b@2:--terrain rugged $MORE --resume $KEEP/rugged_cur.pt" \
    "complex_cur8_b@3:--terrain complex $MORE --step_rise 0.08 --goal_distance 5.5 --resume $KEEP/complex_cur8.pt"
  pick() { if [ -f "$KEEP/$1_b.pt" ]; then echo "$KEEP/$1_b.pt"; else echo "$KEEP/$1.pt"; fi; }
  C=$(pick complex_cur); D=$(pick complex_cur_dr); R=$(pick rugged_cur); C8=$(pick complex_cur8)
  far="--goal_distance 5.5 --distances 1 3 5"
  EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-210} bash scripts/device/eval_jobs.sh \
    "complex25@0:--controllers cpg_rl --checkpoint cpg_rl=$C --terrains complex --rounds 25" \
    "complex1000@0:--controllers cpg_rl --checkpoint cpg_rl=$C --terrains complex --rounds 1000" \
    "stepped25@1:--controllers cpg_rl --checkpoint cpg_rl=$C --terrains stepped --rounds 25" \
    "stepped1000@1:--controllers cpg_rl --checkpoint cpg_rl=$C --terrains stepped --rounds 1000" \
    "stepped1000_c8@1:--controllers cpg_rl --checkpoint cpg_rl=$C8 --terrains stepped --rounds 1000" \
    "rugged25@2:--controllers cpg_rl --checkpoint cpg_rl=$R --terrains rugged --rounds 25" \
    "rugged1000@2:--controllers cpg_rl --checkpoint cpg_rl=$R --terrains rugged --rounds 1000" \
    "far1000_c8@3:--controllers cpg_rl --checkpoint cpg_rl=$C8 --terrains complex --rounds 1000 $far" \
    "far8cm1000_c8@3:--controllers cpg_rl --checkpoint cpg_rl=$C8 --terrains complex --rounds 1000 $far --step_rise 0.08" \
    "perturbed1000@3:--controllers cpg_rl --checkpoint cpg_rl=$C --terrains complex --rounds 1000 --randomize" \
    "perturbed1000_dr@2:--controllers cpg_rl --checkpoint cpg_rl=$D --terrains complex --rounds 1000 --randomize"
  ;;
retrain)   # second lease: a knee-lift floor (--a2_range 0.9 1.3), with and without the curriculum
  HI="--a2_range 0.9 1.3 --seed 1"
  SKIP_WARMUP=1 DEADLINE_S=${DEADLINE_S:-520} bash scripts/device/train_runs.sh \
    "complex_hi_cur@0:--terrain complex $HI --levels 10 --start_levels 3 --target_success 0.95" \
    "complex_hi@1:--terrain complex $HI" \
    "rugged_hi_cur@2:--terrain rugged $HI --levels 10 --start_levels 3" \
    "rugged_hi@3:--terrain rugged $HI"
  ;;
evaluate)  # the retrained runs on their terrains; the first lease's plain and randomised policies, perturbed
  ev() { echo "$1:--controllers cpg_rl --checkpoint cpg_rl=$2 --terrains $3 --rounds $4 ${5:-}"; }
  S=/root/s4ck   # carried in a call of its own and copied there
  EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-170} bash scripts/device/eval_jobs.sh \
    "$(ev complex_hi_cur@0 $KEEP/complex_hi_cur.pt complex 1000)" \
    "$(ev stepped_hi_cur@0 $KEEP/complex_hi_cur.pt stepped 1000)" \
    "$(ev far_hi_cur@0 $KEEP/complex_hi_cur.pt complex 1000 "--goal_distance 5.5 --distances 1 3 5")" \
    "$(ev complex_hi@1 $KEEP/complex_hi.pt complex 1000)" \
    "$(ev stepped_hi@1 $KEEP/complex_hi.pt stepped 1000)" \
    "$(ev rugged_hi_cur@2 $KEEP/rugged_hi_cur.pt rugged 1000)" \
    "$(ev rugged_plain_s4@2 $S/complex_cur.pt rugged 1000)" \
    "$(ev rugged_perturbed_s4@2 $S/complex_cur.pt rugged 1000 --randomize)" \
    "$(ev rugged_hi@3 $KEEP/rugged_hi.pt rugged 1000)" \
    "$(ev rugged_plain_s4_dr@3 $S/complex_cur_dr.pt rugged 1000)" \
    "$(ev rugged_perturbed_s4_dr@3 $S/complex_cur_dr.pt rugged 1000 --randomize)"
  ;;
evaluate1)  # lease 1, after `train` (what ran instead of `continue`)
  ev() { echo "$1:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$2.pt --terrains $3 --rounds 1000 ${4:-}"; }
  EVAL_TIMEOUT_S=170 bash scripts/device/eval_jobs.sh "$(ev c@0 complex_cur complex)" \
    "$(ev dr@1 complex_cur_dr complex)" "$(ev r@2 rugged_cur rugged)" "$(ev c8@3 complex_cur8 stepped)" \
    "$(ev c_st@0 complex_cur stepped)"
  ;;
evaluate2)  # lease 2, after `evaluate`: the rugged jobs that had timed out, one per GPU
  ev() { echo "$1:--controllers cpg_rl --checkpoint cpg_rl=$2 --terrains rugged --rounds 1000 ${3:-}"; }
  EVAL_TIMEOUT_S=150 EVALS=/root/ev2 bash scripts/device/eval_jobs.sh "$(ev rugged_hi_cur@0 $KEEP/rugged_hi_cur.pt)" \
    "$(ev rugged_hi@1 $KEEP/rugged_hi.pt)" "$(ev rugged_perturbed_s4@2 /root/s4ck/complex_cur.pt --randomize)" \
    "$(ev rugged_perturbed_s4_dr@3 /root/s4ck/complex_cur_dr.pt --randomize)"
  ;;
*) echo "usage: curriculum_runs.sh train|continue|evaluate1|retrain|evaluate|evaluate2" >&2; exit 2 ;;
esac
