#!/bin/bash
# Device calls that trained cpg_rl_complex_5m and cpg_rl_stairs8 on one nvidia-h200-x4 lease (after the eight chunk
# calls of pack.sh + rechunk.sh; the last one installs, with the kernel cache), kept as the record of what ran
# (RESULTS.md). Targets:
# >= 99 % at 5 m on complex terrain and on 8 cm steps, 1000 unseen rounds. All runs use the 20 ms frame and the
# default update (2 mini-batches x 4 epochs).
#
#   bash scripts/device/harder_courses.sh train      # 5 m complex (two seeds / batch sizes), 8 cm stairs (two tilts)
#   bash scripts/device/harder_courses.sh evaluate   # 1000 test rounds of each run's last checkpoint, one job per GPU
#   bash scripts/device/harder_courses.sh train2     # each run resumed until the deadline, then 1000 test rounds again
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1 NCCL_NVLS_ENABLE=0
F="--frame_dt 0.02 --substeps 4"
G5="--goal_distance 5.5"
# the complex recipe with the 5 m goal; the stairs themselves with their rise as curriculum (lane k: (k+1)
# x 0.8 cm), the same 5 m goal (all 15 steps, 1.2 m up)
C5="--terrain complex --levels 10 --start_levels 3 --a2_range 0.9 1.3 --randomize $F $G5"
S8="--terrain stepped --step_rise 0.08 --levels 10 --start_levels 3 --a2_range 0.9 1.3 --randomize $F $G5"
RUNS="m5a m5b st8a st8b"
# evaluate args of run $1 (its checkpoint $2): complex at 5 m, or 8 cm stairs at 5 m; 1 and 3 m on the way
ev() {
  local t="complex"; case "$1" in st8*) t="stepped --step_rise 0.08";; esac
  echo "--controllers cpg_rl --checkpoint cpg_rl=$2 --terrains $t --rounds ${R:-1000} --stochastic $G5 --distances 1 3 5"
}
gpu() { case "$1" in m5a*) echo 0;; m5b*) echo 1;; st8a*) echo 2;; st8b*) echo 3;; esac; }
last() { ls -v "$KEEP/$1"/model_*.pt | tail -1; }
evaluate_all() {   # $1: run-name suffix; 1000 test rounds of each run's last checkpoint, one job per GPU
  local jobs=() r
  for r in $RUNS; do jobs+=("$r$1@$(gpu "$r"):$(ev "$r" "$KEEP/$r$1.pt")"); done
  EVALS=/root/evals$1 bash scripts/device/eval_jobs.sh "${jobs[@]}"
}
case "${1:-}" in
train)
  # m5a: 4096 envs, seed 2 (an earlier m5 run had 98.2 % after 8 min with the 4 x 5 update); m5b: 8192 envs, seed 4.
  # st8a / st8b: the 8 cm stairs with Table 1's stability fine from 0.8 rad (46 deg) / pi/6 (the paper's): an
  # earlier s8 run tipped over backward at the first step in 60 % of its rounds (pitch -60 deg), and 8 cm steps pitch the
  # torso ~25 deg on average, so the pi/6 fine fires on a quarter of the climbing steps.
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=${START_S:-15} DEADLINE_S=${DEADLINE_S:-575} bash scripts/device/train_runs.sh \
    "m5a@0:$C5 --seed 2" \
    "m5b@1:$C5 --seed 4 --num_envs 8192" \
    "st8a@2:$S8 --seed 3 --stability_tilt 0.8" \
    "st8b@3:$S8 --seed 3"
  ls "$KEEP"/*/ > "$OUT/kept.txt" 2>&1
  ;;
evaluate)
  EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-330} evaluate_all ""
  ;;
train2)
  # every run resumed from its last checkpoint (the same flags; a resumed run keeps its ranges and physics) until
  # TRAIN_S, then 1000 test rounds of the resumed runs' last checkpoints in what is left of the call
  specs=()
  for r in $RUNS; do
    case "$r" in m5a) a="$C5 --seed 12";; m5b) a="$C5 --seed 14 --num_envs 8192";;
                 st8a) a="$S8 --seed 13 --stability_tilt 0.8";; st8b) a="$S8 --seed 13";; esac
    specs+=("${r}2@$(gpu "$r"):${a/--a2_range 0.9 1.3 /} --resume $(last "$r")")
  done
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=0 DEADLINE_S=${TRAIN_S:-400} bash scripts/device/train_runs.sh "${specs[@]}"
  EVAL_TIMEOUT_S=$(( ${DEADLINE_S:-590} - SECONDS )) evaluate_all 2
  ;;
train3)
  # st8a2 resumed on three seeds until TRAIN_S; 1000 validation rounds (evaluate --seed 3000) pick one, whose
  # 1000 test rounds (sampled and expected actions) are the report
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=0 DEADLINE_S=${TRAIN_S:-300} bash scripts/device/train_runs.sh \
    "st8a3s23@0:${S8/--a2_range 0.9 1.3 /} --seed 23 --stability_tilt 0.8 --resume $(last st8a2)" \
    "st8a3s33@1:${S8/--a2_range 0.9 1.3 /} --seed 33 --stability_tilt 0.8 --resume $(last st8a2)" \
    "st8a3s43@2:${S8/--a2_range 0.9 1.3 /} --seed 43 --stability_tilt 0.8 --resume $(last st8a2)"
  jobs=(); for r in st8a3s23@0 st8a3s33@1 st8a3s43@2; do jobs+=("val_$r:$(ev st8 "$KEEP/${r%@*}.pt") --seed 3000"); done
  EVALS=/root/val3 EVAL_TIMEOUT_S=120 bash scripts/device/eval_jobs.sh "${jobs[@]}"; mv "$OUT/evals.tgz" "$OUT/val3.tgz"
  best=$(python -c "import json,sys; r={n: json.load(open(f'/root/val3/val_{n}/results.json'))['results']['stepped']['cpg_rl']['success_5m'] for n in sys.argv[1:]}; print(max(r, key=r.get))" st8a3s23 st8a3s33 st8a3s43)
  echo "best on validation: $best"
  EVALS=/root/test3 EVAL_TIMEOUT_S=$(( ${DEADLINE_S:-480} - SECONDS )) bash scripts/device/eval_jobs.sh \
    "test_$best@0:$(ev st8 "$KEEP/$best.pt")" "test_${best}_expected@1:$(ev st8 "$KEEP/$best.pt" | sed 's/--stochastic/--expected/')"
  ;;
*) echo "usage: harder_courses.sh train|evaluate|train2|train3" >&2; exit 2;;
esac
