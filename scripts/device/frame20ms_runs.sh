#!/bin/bash
# Device calls of the 20 ms-frame runs (cpg_rl_complex_6min, the SB3 baselines, time-to-skill) on one
# nvidia-h200-x4 lease (after the eight chunk calls of pack.sh + rechunk.sh), kept as the record of what ran
# (RESULTS.md / BENCHMARKS.md). The first call also installs (.dw3b), the
# Stable-Baselines3 wheels (runs/sb3w), the precompiled kernel cache and the shipped policy's full checkpoint.
#
#   bash scripts/device/frame20ms_runs.sh train     # cres_std + SAC/TD3/A2C-CPG on GPU 0, time-to-skill on 1 and on 2+3
#   bash scripts/device/frame20ms_runs.sh evaluate  # 1000-round evaluations of those, the fast-physics bench, a video
#   bash scripts/device/frame20ms_runs.sh train2    # the time-to-skill run under the fast physics, and the harder-course runs
set -u
OUT=${OUT:-out}
KEEP=/root/keep
export KEEP PYTHONUNBUFFERED=1 NCCL_NVLS_ENABLE=0
C="--terrain complex --levels 10 --start_levels 3 --a2_range 0.9 1.3 --randomize"   # the recipe of cpg_rl_complex_7min
MORE="--terrain complex --levels 10 --start_levels 10 --randomize"                # resumed: every lane at once
ev() { echo "--controllers cpg_rl --checkpoint cpg_rl=$1 --terrains $2 --rounds ${R:-1000} ${3:-}"; }
nth_last() { ls -v "$KEEP/$1"/model_*.pt | tail -"$2" | head -1; }   # a run's N-th last saved checkpoint
case "${1:-}" in
train)
  # the paper's SB3 baselines on complex terrain, sharing GPU 0 with cres_std (they are CPU-bound)
  for a in sac td3 a2c; do
    CUDA_VISIBLE_DEVICES=0 timeout -k 10 "${SB3_S:-530}" python -m hexnewton.baselines --algo $a --terrain complex \
      --num_envs 4096 --total_steps 1000000000 --max_minutes "${SB3_MIN:-7.4}" --seed 1 --device cuda \
      --log_dir /root/sb3 > /root/sb3_$a.log 2>&1 &
  done
  # cres_std: cpg_rl_complex_7min (complex_dr_s5_model_768) with its std fixed at 0.3, so that the mean
  # action learns what the noise did; tts: that recipe from scratch (time-to-skill), alone on its
  # GPU; tts_2gpu: the same through torchrun on two GPUs
  KEEP_ALL=1 SKIP_WARMUP=1 START_S=${START_S:-25} DEADLINE_S=${DEADLINE_S:-560} bash scripts/device/train_runs.sh \
    "cres_std@0:$MORE --resume /root/ck/complex_dr.pt --seed 4 --action_std 0.3" \
    "tts@1:$C --seed 1 --target_success 0.97" \
    "tts_2gpu@2,3:$C --seed 1 --target_success 0.97"
  wait
  tar czf "$OUT/sb3.tgz" -C /root sb3 sb3_sac.log sb3_td3.log sb3_a2c.log
  for a in sac td3 a2c; do echo "== $a: $(tail -2 /root/sb3_$a.log | tr '\n' ' ')"; done
  ;;
evaluate)
  ( export CUDA_VISIBLE_DEVICES=3
    b() { timeout -k 5 "$1" python -m hexnewton.bench "${@:2}" --append "$OUT/BENCHMARKS.md" >> "$OUT/bench.log" 2>&1; }
    b 100 --num_envs 16384 --terrain flat complex --mode sim --frames 200 --frame_dt 0.02 --substeps 4
    b 100 --num_envs 4096 --terrain complex --mode sim env train --frame_dt 0.02 --substeps 4 --profile
    b 80 --num_envs 16384 --terrain flat complex --mode sim --frames 200 --frame_dt 0.02 --substeps 3
    timeout -k 5 60 python play.py --controller cpg_rl --checkpoint "$KEEP/cres_std.pt" --terrain complex \
      --num_envs 16 --steps 1000 --seed 1000 --reset_yaw 0.2 --video "$OUT/video_gpu.gif" --video_speed 2 \
      --no-progress > "$OUT/video.log" 2>&1 ) &
  EVALS=/root/evals_e EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-300} bash scripts/device/eval_jobs.sh \
    "std_complex_mean@0:$(ev $KEEP/cres_std.pt complex)" \
    "std_complex_sampled@0:$(ev $KEEP/cres_std.pt complex --stochastic)" \
    "std_stepped_mean@0:$(ev $KEEP/cres_std.pt stepped)" \
    "std_rugged_mean@0:$(ev $KEEP/cres_std.pt rugged)" \
    "tts_last@1:$(ev $KEEP/tts.pt complex --stochastic)" \
    "tts_m1@1:$(R=500 ev "$(nth_last tts 2)" complex --stochastic)" \
    "tts_m2@1:$(R=500 ev "$(nth_last tts 3)" complex --stochastic)" \
    "g2_last@2:$(ev $KEEP/tts_2gpu.pt complex --stochastic)" \
    "g2_m1@2:$(R=500 ev "$(nth_last tts_2gpu 2)" complex --stochastic)" \
    "g2_m2@2:$(R=500 ev "$(nth_last tts_2gpu 3)" complex --stochastic)" \
    "std_5m_mean@2:$(ev $KEEP/cres_std.pt complex '--goal_distance 5.5 --distances 1 3 5')"
  wait
  ls "$KEEP"/tts "$KEEP"/tts_2gpu > "$OUT/kept.txt" 2>&1
  grep -E "robot-s/s|error" "$OUT/bench.log" | tail -20; tail -2 "$OUT/video.log"
  ;;
train2)
  # FAST=1 (the bench confirmed the 20 ms frame): the time-to-skill run under it; the harder-course runs resume cres_std
  PHYS=""; [ "${FAST:-1}" = 1 ] && PHYS="--frame_dt 0.02 --substeps 4"
  SKIP_WARMUP=1 START_S=0 DEADLINE_S=${DEADLINE_S:-420} bash scripts/device/train_runs.sh \
    "tts_fast@0:$C --seed 1 --target_success 0.97 $PHYS" \
    "std_5m@1:$MORE --resume $KEEP/cres_std.pt --seed 5 --action_std 0.3 --goal_distance 5.5" \
    "std_8cm@2:$MORE --resume $KEEP/cres_std.pt --seed 6 --action_std 0.3 --goal_distance 5.5 --step_rise 0.08" \
    "std_more@3:$MORE --resume $KEEP/cres_std.pt --seed 7 --action_std 0.3"
  EVALS=/root/evals_t2 EVAL_TIMEOUT_S=${EVAL_TIMEOUT_S:-110} R=500 bash scripts/device/eval_jobs.sh \
    "fast_own@0:$(ev $KEEP/tts_fast.pt complex --stochastic)" \
    "fast_default@1:$(ev $KEEP/tts_fast.pt complex '--stochastic --frame_dt 0.01 --substeps 4')" \
    "more_mean@2:$(ev $KEEP/std_more.pt complex)" \
    "s5m_mean@3:$(ev $KEEP/std_5m.pt complex '--goal_distance 5.5 --distances 1 3 5')"
  ;;
*) echo "usage: frame20ms_runs.sh train|evaluate|train2" >&2; exit 2;;
esac
