#!/bin/bash
# Device calls that trained and measured the body-posture policies (RESULTS.md, "Stable gaits"), on one nvidia-h200,
# after the chunk calls of ../shared/device/pack.sh + rechunk.sh (the last one installs, with runs/warpcache.tgz
# from scripts/device/precompile.py).
#
#   bash scripts/device/posture_gait.sh train     # three posture variants of the complex recipe at once on one GPU
#   bash scripts/device/posture_gait.sh validate  # 250 validation rounds of each on rugged and complex ground, then
#                                                 # the chosen one on 1000 test rounds per terrain; the fixed CPG's
#                                                 # rugged test rounds beside
#   bash scripts/device/posture_gait.sh robust    # the chosen policy under each named perturbation (300 complex rounds)
#   bash scripts/device/posture_gait.sh fixed     # the fixed CPG's stepped and complex test rounds
#   bash scripts/device/posture_gait.sh level     # the reflex policy (ps) resumed under stronger tilt shaping / gain
#   bash scripts/device/posture_gait.sh validate_level  # 300 validation rounds of each on the three terrains
#   bash scripts/device/posture_gait.sh test_level      # the chosen one (la, shipped as cpg_rl_complex) on 1000 test
#                                                       # rounds per terrain, the fixed gaits' rugged rounds beside
#   PERTURBATIONS="nominal friction_0.3 ..." bash scripts/device/posture_gait.sh robust   # (results/stable_gait)
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1
VARIANTS=${VARIANTS:-"ra rb rc"}
FIXED_PHYSICS="--frame_dt 0.02 --substeps 4"   # the complex recipe's physics (RECIPES), which the learnt policies use
SWEPT="--swept_gait 6.283185307179586 0.2 0.9 0.3"
chosen() { cat "$KEEP/chosen" 2>/dev/null; }
case "${1:-}" in
train)
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=${START_S:-0} DEADLINE_S=${DEADLINE_S:-585} bash scripts/device/train_runs.sh \
    "ra:--terrain complex --seed 1 --posture --posture_reflex 2" \
    "rb:--terrain complex --seed 1 --posture --posture_reflex 4" \
    "rc:--terrain complex --seed 1 --posture --posture_reflex 2 --w_tilt 15 --w_ang_vel 0.1"
  ;;
validate)
  # each variant's best checkpoint (train_runs.sh keeps model_best.pt as $KEEP/<name>.pt) and its last one
  jobs=()
  for r in $VARIANTS; do
    cp "$(ls -v "$KEEP/$r"/model_[0-9]*.pt | tail -1)" "$KEEP/${r}_last.pt"
    for c in $r ${r}_last; do
      jobs+=("val_$c:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$c.pt --terrains rugged complex --rounds 250 --seed 3000 --max_steps 3000")
    done
  done
  fixed="--rounds 1000 --terrains rugged $FIXED_PHYSICS"
  EVALS=/root/test EVAL_TIMEOUT_S=570 bash scripts/device/eval_jobs.sh "rugged_cpg:--controllers cpg $fixed" \
    "rugged_cpg_swept:--controllers cpg_swept $SWEPT $fixed" > /root/fixed.txt 2>&1 &
  EVALS=/root/val EVAL_TIMEOUT_S=220 bash scripts/device/eval_jobs.sh "${jobs[@]}"
  mv "$OUT/evals.tgz" "$OUT/val.tgz"
  # >= 99 % at 3 m and <= 0.5 % falls on both terrains first, then the smallest rugged pitch + roll variance
  best=$(python scripts/device/choose_variant.py $(for r in $VARIANTS; do echo $r ${r}_last; done))
  echo "$best" > "$KEEP/chosen"; echo "chosen on validation: $best"
  cp "$KEEP/$best.pt" "$OUT/chosen_$best.pt"
  ck="--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$best.pt --rounds 1000"
  EVALS=/root/test EVAL_TIMEOUT_S=$(( 585 - SECONDS )) bash scripts/device/eval_jobs.sh \
    "rugged_cpg_rl:$ck --terrains rugged" "stepped_cpg_rl:$ck --terrains stepped" "complex_cpg_rl:$ck --terrains complex"
  wait
  cat /root/fixed.txt
  tar czf "$OUT/test.tgz" -C /root test
  ;;
robust)
  ck="--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$(chosen).pt --terrains complex --rounds 300"
  jobs=()
  # PERTURBATIONS: a subset per call (nine 300-round jobs at once ran past 420 s; five take ~300 s)
  for p in ${PERTURBATIONS:-nominal friction_0.3 payload_0.8kg motors_0.6 push_0.6m/s latency_40ms sensor_noise_x2 steps_7cm blocks_8cm}; do
    jobs+=("robust_${p//\//_}:$ck --perturbations $p")
  done
  EVALS=/root/robust EVAL_TIMEOUT_S=$(( 585 - SECONDS )) bash scripts/device/eval_jobs.sh "${jobs[@]}"
  ;;
fixed)
  fixed="--rounds 1000 $FIXED_PHYSICS"
  EVALS=/root/fixed EVAL_TIMEOUT_S=$(( 585 - SECONDS )) bash scripts/device/eval_jobs.sh \
    "stepped_cpg:--controllers cpg $fixed --terrains stepped" \
    "stepped_cpg_swept:--controllers cpg_swept $SWEPT $fixed --terrains stepped" \
    "complex_cpg:--controllers cpg $fixed --terrains complex" \
    "complex_cpg_swept:--controllers cpg_swept $SWEPT $fixed --terrains complex"
  ;;
compare)
  # validation rounds on rugged ground: the fixed gaits with and without the levelling reflex, the posture policy
  # trained without it (runs/posture/pa.pt) with and without it, and the one trained with it (rc2.pt)
  v="--terrains rugged --rounds 300 --seed 3000 --max_steps 3000"
  f="$v $FIXED_PHYSICS"
  EVALS=/root/compare EVAL_TIMEOUT_S=$(( 570 - SECONDS )) bash scripts/device/eval_jobs.sh \
    "cpg:--controllers cpg $f" "cpg_swept:--controllers cpg_swept $SWEPT $f" \
    "cpg_swept_reflex2:--controllers cpg_swept $SWEPT $f --posture_reflex 2" \
    "pa:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/pa.pt $v" \
    "pa_reflex2:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/pa.pt $v --posture_reflex 2" \
    "rc2:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/rc2.pt $v"
  ;;
finetune)
  # the posture policy (runs/posture/pa.pt, with its optimiser state, in $KEEP) resumed under the reflex it lacks
  KEEP_ALL=0 SKIP_WARMUP=1 START_S=${START_S:-0} DEADLINE_S=${DEADLINE_S:-540} bash scripts/device/train_runs.sh \
    "pr:--terrain complex --seed 3 --resume $KEEP/pa.pt --posture_reflex 2" \
    "ps:--terrain complex --seed 3 --resume $KEEP/pa.pt --posture_reflex 2 --w_tilt 15 --w_ang_vel 0.1"
  cp "$KEEP/pr.pt" "$KEEP/ps.pt" "$OUT/"
  ;;
validate_finetune)
  v="--rounds 300 --seed 3000 --max_steps 3000"
  jobs=()
  for r in pr ps; do for t in rugged complex; do
    jobs+=("${r}_$t:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$r.pt --terrains $t $v")
  done; done
  EVALS=/root/finetune EVAL_TIMEOUT_S=$(( 500 - SECONDS )) bash scripts/device/eval_jobs.sh "${jobs[@]}"
  ;;
level)
  # ps (runs/posture/ps.pt, with its optimiser state, in $KEEP) resumed with a stronger tilt penalty and reflex gain
  r="--terrain complex --seed 4 --resume $KEEP/ps.pt"
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=${START_S:-0} DEADLINE_S=${DEADLINE_S:-540} bash scripts/device/train_runs.sh \
    "la:$r --posture_reflex 2 --w_tilt 40 --w_ang_vel 0.3" \
    "lb:$r --posture_reflex 4 --w_tilt 40 --w_ang_vel 0.3" \
    "lc:$r --posture_reflex 3 --w_tilt 100 --w_ang_vel 0.5"
  for r in la lb lc; do cp "$KEEP/$r.pt" "$OUT/$r.pt"; cp "$(ls -v "$KEEP/$r"/model_[0-9]*.pt | tail -1)" "$OUT/${r}_last.pt"; done
  ;;
validate_level)
  v="--rounds 300 --seed 3000 --max_steps 3000"
  jobs=()
  for r in ${VARIANTS:-la lb lc}; do
    jobs+=("val_$r:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$r.pt --terrains rugged complex stepped $v")
  done
  EVALS=/root/val EVAL_TIMEOUT_S=$(( 560 - SECONDS )) bash scripts/device/eval_jobs.sh "${jobs[@]}"
  python scripts/device/choose_variant.py ${VARIANTS:-la lb lc}
  ;;
test_level)
  # the variant chosen on validation (la) on 1000 test rounds per terrain, the fixed CPG's rugged test rounds beside
  echo la > "$KEEP/chosen"
  ck="--controllers cpg_rl --checkpoint cpg_rl=$KEEP/la.pt --rounds 1000"
  fixed="--rounds 1000 --terrains rugged $FIXED_PHYSICS"
  EVALS=/root/test EVAL_TIMEOUT_S=$(( 560 - SECONDS )) bash scripts/device/eval_jobs.sh \
    "rugged_cpg_rl:$ck --terrains rugged" "stepped_cpg_rl:$ck --terrains stepped" "complex_cpg_rl:$ck --terrains complex" \
    "rugged_cpg:--controllers cpg $fixed" "rugged_cpg_swept:--controllers cpg_swept $SWEPT $fixed"
  ;;
*) echo "usage: posture_gait.sh train|validate|robust|fixed|compare|finetune|validate_finetune|level|validate_level|test_level" >&2
   exit 2;;
esac
