#!/bin/bash
# Device calls that trained and measured the stable complex policy (RESULTS.md, "Stable gaits"), on one nvidia-h200,
# after the chunk calls of ../shared/device/pack.sh + rechunk.sh (the last one installs, with runs/warpcache.tgz
# from scripts/device/precompile.py).
#
#   bash scripts/device/stable_gait.sh train     # three stable-gait variants on one GPU, the fixed-gait sweep beside
#   bash scripts/device/stable_gait.sh train2    # three more variants (stronger shaping, resumed, lower knee floor)
#   bash scripts/device/stable_gait.sh validate  # validation rounds of each variant (VARIANTS="sd se sf" for those)
#   bash scripts/device/stable_gait.sh test    # the variant chosen on validation: 1000 test rounds per terrain
#                                              # (fixed CPG default and swept beside it), robustness report
#   bash scripts/device/stable_gait.sh report    # the shipped Beta policy on 1000 test rounds, fixed gaits beside
#   bash scripts/device/stable_gait.sh robust    # its robustness report; rugged rounds under the 10 ms frame
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1
VARIANTS=${VARIANTS:-"sa sb sc"}
case "${1:-}" in
train)
  # the fixed-gait sweep (180 gaits x 8 rounds per terrain) beside the training runs
  ( python -m hexnewton.cpg_sweep --rounds 8 --frame_dt 0.02 --substeps 4 --out /root/sweep > /root/sweep.log 2>&1
    tar czf "$OUT/sweep.tgz" -C /root sweep sweep.log ) &
  # python train.py --terrain complex (its recipe) with the Beta actions and the default shaping (sa), with the
  # slower parameter filter (sb), and with both plus stronger shaping (sc)
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=${START_S:-40} DEADLINE_S=${DEADLINE_S:-560} bash scripts/device/train_runs.sh \
    "sa:--terrain complex --seed 1" \
    "sb:--terrain complex --seed 1 --param_tau 0.1" \
    "sc:--terrain complex --seed 1 --param_tau 0.1 --w_tilt 5 --w_ang_vel 0.05 --w_action_rate 0.1"
  wait
  ;;
train2)
  # stronger shaping from scratch (sd), sc resumed with it (se), and the knee-lift floor lowered to 0.5 rad (sf)
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=0 DEADLINE_S=520 bash scripts/device/train_runs.sh \
    "sd:--terrain complex --seed 1 --param_tau 0.1 --w_tilt 20 --w_ang_vel 0.2 --w_action_rate 0.1" \
    "se:--terrain complex --seed 2 --resume $KEEP/sc.pt --w_tilt 20 --w_ang_vel 0.2 --w_action_rate 0.1" \
    "sf:--terrain complex --seed 1 --param_tau 0.1 --a2_range 0.5 1.3 --w_tilt 10 --w_ang_vel 0.1 --w_action_rate 0.1"
  ;;
validate)
  # 250 validation rounds (evaluate --seed 3000) of each variant on rugged and complex ground, 60 s each at most
  jobs=()
  for r in $VARIANTS; do
    jobs+=("val_$r:--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$r.pt --terrains rugged complex --rounds 250 --seed 3000 --max_steps 3000")
  done
  EVALS=/root/val EVAL_TIMEOUT_S=200 bash scripts/device/eval_jobs.sh "${jobs[@]}"
  mv "$OUT/evals.tgz" "$OUT/val.tgz"
  ;;
test)
  # the variant with >= 99 % at 3 m on every terrain and <= 0.5 % falls, then the smallest rugged pitch + roll
  # variance (else the best mean success), on validation rounds
  best=$(python scripts/device/choose_variant.py $VARIANTS)
  gait=$(python -c "import json; b=json.load(open('/root/sweep/results.json'))['best']; print(b['omega'], b['a1'], b['a2'], b['a3'])")
  echo "chosen on validation: $best; swept gait: $gait"
  ck="--checkpoint cpg_rl=$KEEP/$best.pt"
  t3="--controllers cpg cpg_swept cpg_rl $ck --swept_gait $gait --rounds 1000"
  rb="--controllers cpg_rl $ck --terrains complex --rounds 500"
  EVALS=/root/test EVAL_TIMEOUT_S=$(( ${CALL_S:-585} - SECONDS - 15 )) bash scripts/device/eval_jobs.sh \
    "rugged:$t3 --terrains rugged" "stepped:$t3 --terrains stepped" "complex:$t3 --terrains complex" \
    "robust1:$rb --perturbations friction_0.3 payload_0.8kg motors_0.6" \
    "robust2:$rb --perturbations push_0.6m/s latency_40ms sensor_noise_x2" \
    "robust3:$rb --perturbations steps_7cm blocks_8cm"
  cp "$KEEP/$best.pt" "$OUT/chosen_$best.pt"
  ;;
report)
  # the chosen variant (sc, shipped as results/policies/cpg_rl_complex_beta.pt) on 1000 test rounds per terrain beside
  # the fixed CPG (default and swept gait), one controller and terrain per job (six at once on one GPU; three
  # controllers per job ran past a 560 s call on rugged and complex); evaluate --merge joins them afterwards
  ck="--checkpoint cpg_rl=results/policies/cpg_rl_complex_beta.pt"
  jobs=()
  for t in ${TERRAINS:-rugged complex}; do
    for c in cpg cpg_swept cpg_rl; do jobs+=("${t}_$c:--controllers $c $ck --terrains $t --rounds 1000"); done
  done
  EVALS=/root/test EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-540} bash scripts/device/eval_jobs.sh "${jobs[@]}"
  ;;
robust)
  # the robustness report (300 complex rounds per named perturbation), and the rugged rounds under the 10 ms frame
  ck="--checkpoint cpg_rl=results/policies/cpg_rl_complex_beta.pt"
  rb="--controllers cpg_rl $ck --terrains complex --rounds 300"
  EVALS=/root/robust EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-330} bash scripts/device/eval_jobs.sh \
    "robust1:$rb --perturbations friction_0.3 payload_0.8kg motors_0.6" \
    "robust2:$rb --perturbations push_0.6m/s latency_40ms sensor_noise_x2" \
    "robust3:$rb --perturbations steps_7cm blocks_8cm" \
    "frame10ms:--controllers cpg cpg_rl $ck --terrains rugged --rounds 300 --frame_dt 0.01 --substeps 4"
  ;;
*) echo "usage: stable_gait.sh train|train2|validate|test|report|robust" >&2; exit 2;;
esac
