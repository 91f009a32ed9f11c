#!/bin/bash
# Device calls that trained cpg_rl_complex_7min on one nvidia-h200-x4 lease (after the three chunk calls of
# pack.sh), kept as the record of what ran (RESULTS.md). The first call also installs (.dw3), unpacks the precompiled
# kernel cache (precompile.py) and copies the carried checkpoints (runs/ck) to /root/ck.
#
#   bash scripts/device/complex_7min.sh train_a   # lease 1: with the off-course penalty; found the missed-goal problem
#   bash scripts/device/complex_7min.sh train     # lease 2: goal bonus 300 and the robot-to-goal direction term
#   bash scripts/device/complex_7min.sh evaluate  # lease 2: 1000-round evaluations, Table 3 (25 rounds) and the bench
#   bash scripts/device/complex_7min.sh evaluate2 # lease 3: the same policies with sampled actions (--stochastic)
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1
C="--terrain complex --levels 10 --start_levels 3"
MORE="--terrain complex --levels 10 --start_levels 10"   # a resumed run starts spread over every lane
case "${1:-}" in
train_a)
  CK=/root/ck/complex_hi_cur.pt   # device-cache: ckpt/complex_hi_cur_s4_model_878.pt
  SKIP_WARMUP=1 START_S=20 DEADLINE_S=530 bash scripts/device/train_runs.sh \
    "complex@0:$C --a2_range 0.9 1.3 --seed 1 --target_success 0.95" \
    "cres@1:$C --resume $CK --seed 2" \
    "cres_dr@2:$C --resume $CK --seed 2 --randomize" \
    "c8@3:$C --step_rise 0.08 --goal_distance 5.5 --resume $CK --seed 3"
  ;;
train)
  CK=/root/ck/cres_dr_a.pt        # train_a's cres_dr (52 % of its last training episodes reached the goal)
  SKIP_WARMUP=1 START_S=20 DEADLINE_S=${DEADLINE_S:-520} bash scripts/device/train_runs.sh \
    "complex@0:$C --a2_range 0.9 1.3 --seed 1 --target_success 0.95" \
    "complex_dr@1:$C --a2_range 0.9 1.3 --seed 1 --randomize" \
    "cres@2:$MORE --resume $CK --seed 2" \
    "c8@3:$MORE --step_rise 0.08 --goal_distance 5.5 --resume $CK --seed 3"
  ;;
evaluate)
  ev() { echo "--controllers cpg_rl --checkpoint cpg_rl=$KEEP/$1.pt --terrains $2 --rounds 1000 ${3:-}"; }
  CUDA_VISIBLE_DEVICES=3 timeout ${BENCH_S:-330} python -m hexnewton.bench --num_envs 1024 4096 16384 \
    --terrain flat complex --mode sim env train --profile --append "$OUT/BENCHMARKS.md" --json "$OUT/bench.json" \
    > "$OUT/bench.log" 2>&1 &
  EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-320} bash scripts/device/eval_jobs.sh \
    "complex_complex@0:$(ev complex complex)" \
    "complex_stepped@0:$(ev complex stepped)" \
    "cres_complex@1:$(ev cres complex)" \
    "cres_stepped@1:$(ev cres stepped)" \
    "table3@1:--controllers cpg cpg_rl --checkpoint cpg_rl:rugged=$KEEP/cres.pt cpg_rl:stepped=$KEEP/cres.pt cpg_rl:complex=$KEEP/cres.pt --terrains rugged stepped complex --rounds 25" \
    "dr_plain@2:$(ev complex complex --randomize)" \
    "dr_dr@2:$(ev complex_dr complex --randomize)" \
    "c8@2:$(ev c8 complex '--step_rise 0.08 --goal_distance 5.5 --distances 1 3 5')" \
    "cres_5m@0:$(ev cres complex '--goal_distance 5.5 --distances 1 3 5')"
  wait
  tail -5 "$OUT/bench.log"
  ;;
evaluate2)   # lease 3: the policies' sampled actions (evaluate --stochastic); runs/ck2 = actor-only copies of KEEP
  ev() { echo "--controllers cpg_rl --checkpoint cpg_rl=/root/ck2/$1.pt --terrains $2 --rounds 1000 --stochastic ${3:-}"; }
  EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-200} bash scripts/device/eval_jobs.sh \
    "s_complex@0:$(ev complex_dr complex)" \
    "s_stepped@1:$(ev complex_dr stepped)" \
    "s_rugged@2:$(ev complex_dr rugged)" \
    "s_plain_perturbed@2:$(ev complex complex --randomize)" \
    "s_dr_perturbed@3:$(ev complex_dr complex --randomize)"
  ;;
*) echo "usage: complex_7min.sh train_a|train|evaluate|evaluate2" >&2; exit 2;;
esac
