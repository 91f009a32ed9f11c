#!/bin/bash
# Device calls that trained cpg_rl_complex_gaussian (the complex recipe on one and on two GPUs) on one
# nvidia-h200-x4 lease, after the eight chunk calls of pack.sh + rechunk.sh (the last one installs, with the
# Stable-Baselines3 wheels and the kernel cache); the record of what ran for RESULTS.md / BENCHMARKS.md. Every run
# uses the 20 ms frame (4 x 5 ms) and stores each action with its own observation.
#
#   bash scripts/device/complex_2gpu.sh train    # time-to-skill, 5 m and 8 cm runs from scratch; PPO-update bench
#   bash scripts/device/complex_2gpu.sh train2   # 2 x 2048 torchrun, a faster-update run, 5 m / 8 cm with a std cap
#   bash scripts/device/complex_2gpu.sh table3   # Table 3 (25 rounds) on the GPU machine; 1000-round evaluations
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1 NCCL_NVLS_ENABLE=0
F="--frame_dt 0.02 --substeps 4"
C="--terrain complex --levels 10 --start_levels 3 --a2_range 0.9 1.3 --randomize $F"   # the complex recipe
ev() { echo "--controllers cpg_rl --checkpoint cpg_rl=$1 --terrains $2 --rounds ${R:-1000} --stochastic ${3:-}"; }
nth_last() { ls -v "$KEEP/$1"/model_*.pt | tail -"$2" | head -1; }   # a run's N-th last saved checkpoint
G5="--goal_distance 5.5 --distances 1 3 5"
case "${1:-}" in
train)
  # GPU 3: the training / sim-only ratio at 4096 envs with rsl-rl's update options (same PPO maths:
  # torch.compile, bfloat16 autocast; changed maths: 2 mini-batches of 49,152 samples instead of 4)
  ( export CUDA_VISIBLE_DEVICES=3
    b() { local t=$(( ${DEADLINE_S:-570} - ${START_S:-20} - SECONDS )); [ "$t" -gt "$1" ] && t=$1; [ "$t" -gt 30 ] || return
          timeout -k 5 "$t" python -m hexnewton.bench --num_envs 4096 --terrain complex "${@:2}" $F --profile \
            --append "$OUT/BENCHMARKS.md" >> "$OUT/bench.log" 2>&1; echo "bench ${*:2}: exit $?" >> "$OUT/bench.log"; }
    b 150 --mode sim env train
    b 120 --mode train --mixed_precision
    b 150 --mode train --torch_compile default
    b 150 --mode train --torch_compile default --mixed_precision
    b 120 --mode train --num_mini_batches 2
    b 150 --mode train --num_mini_batches 2 --torch_compile default --mixed_precision
    b 120 --mode train --num_mini_batches 2 --num_learning_epochs 4 ) &
  # tts7: the time-to-skill recipe with correct data; m5: 5 m goal; s8: 8 cm steps, all from scratch
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=${START_S:-20} DEADLINE_S=${DEADLINE_S:-570} bash scripts/device/train_runs.sh \
    "tts7@0:$C --seed 1 --target_success 0.97" \
    "m5@1:$C --seed 2 --goal_distance 5.5" \
    "s8@2:$C --seed 3 --step_rise 0.08"
  wait
  grep -E "robot-s/s|exit|rror" "$OUT/bench.log" | tail -40
  ;;
train2)
  # a new lease: train's last checkpoints (actor-only copies, runs/ck7) came with the install call into $KEEP.
  # 2 x 2048 envs through torchrun (the same samples per update as one GPU's 4096); the recipe
  # with the fastest update of train's bench (2 mini-batches, 4 epochs); 5 m and 8 cm with the std capped
  # (train's runs grew it to 3.9 and 5.8), both on GPU 3
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=0 DEADLINE_S=${DEADLINE_S:-450} bash scripts/device/train_runs.sh \
    "g2x2048@0,1:$C --seed 1 --target_success 0.97 --num_envs 2048" \
    "fastup@2:$C --seed 1 --target_success 0.97 ${UPDATE:---num_mini_batches 2 --num_learning_epochs 4}" \
    "m5cap@3:$C --seed 2 --goal_distance 5.5 --std_max 1.0" \
    "s8cap@3:$C --seed 3 --step_rise 0.08 --std_max 1.0"
  ls "$KEEP"/*/ > "$OUT/kept.txt" 2>&1
  ;;
table3)
  # Table 3 on the GPU machine (CPG_RL = $POLICY, the SB3 models carried in runs/sb3m): rugged and stepped
  # on GPU 0, complex on GPU 1; the 1000-round evaluations of train's and train2's runs on GPUs 1-3
  # (as run, this call lacked the mkdir and every Table-3 job failed at once; a second call, one terrain per GPU with
  # 280 s each, ran out of time after the CPG and CPG_RL rows: 25 robots are launch-bound on the GPU. RESULTS.md)
  S=runs/sb3m
  mkdir -p /root/t3
  for t in rugged:0 stepped:0 complex:1; do
    ( CUDA_VISIBLE_DEVICES=${t#*:} timeout -k 10 "${T3_S:-420}" python -m hexnewton.evaluate \
        --controllers cpg cpg_rl sac_cpg td3_cpg a2c_cpg --checkpoint cpg_rl="${POLICY:-$KEEP/tts7.pt}" \
        sac_cpg=$S/sac.zip td3_cpg=$S/td3.zip a2c_cpg=$S/a2c.zip --terrains "${t%:*}" --rounds 25 --stochastic \
        --out "/root/t3/${t%:*}" --no-progress > "/root/t3_${t%:*}.log" 2>&1; echo "exit $?" >> "/root/t3_${t%:*}.log" ) &
  done
  EVALS=/root/evals_e EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-400} bash scripts/device/eval_jobs.sh \
    "tts7@1:$(ev $KEEP/tts7.pt complex)" \
    "m5@2:$(ev $KEEP/m5.pt complex "$G5")" \
    "m5cap@2:$(ev $KEEP/m5cap.pt complex "$G5")" \
    "s8@3:$(ev $KEEP/s8.pt stepped '--step_rise 0.08')" \
    "s8cap@3:$(ev $KEEP/s8cap.pt stepped '--step_rise 0.08')" \
    "g2x2048@1:$(ev $KEEP/g2x2048.pt complex)" \
    "fastup@2:$(ev $KEEP/fastup.pt complex)"
  wait
  tar czf "$OUT/table3.tgz" -C /root t3 t3_rugged.log t3_stepped.log t3_complex.log
  for t in rugged stepped complex; do tail -1 /root/t3_$t.log; grep -E '^\| '$t' \|' /root/t3/$t/report.md | head -6; done
  ;;
*) echo "usage: complex_2gpu.sh train|train2|table3" >&2; exit 2;;
esac
