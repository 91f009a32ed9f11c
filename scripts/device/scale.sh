#!/bin/bash
# Data-parallel scaling on the device tool's nvidia-h200-x2: training throughput on 1 and 2 GPUs at the same envs per GPU
# (torchrun + rsl-rl's NCCL mode), then a complex-terrain run on 2 GPUs from a fixed seed until the deadline
# (time-to-skill; --target_success is single-process only, so the curve is read from the log).
#
#   ENVS=4096 ITERS=25 DEADLINE_S=560 bash scripts/device/scale.sh
set -u
OUT=${OUT:-out}
START=${START_S:-0}
DEADLINE=${DEADLINE_S:-560}
ENVS=${ENVS:-4096}
ITERS=${ITERS:-25}
mkdir -p "$OUT"
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"
for g in 1 2; do
  t=$SECONDS
  torchrun --standalone --nproc_per_node=$g train.py --terrain complex --num_envs "$ENVS" --max_iterations "$ITERS" \
    --seed 1 --log_dir /root/scale --experiment "gpus$g" > "$OUT/scale_$g.log" 2>&1
  echo "exit $? after $((SECONDS - t)) s" >> "$OUT/scale_$g.log"
  # mean total steps/s (all GPUs) over the iterations after the first five
  echo "$g GPU(s): $(grep 'Steps per second' "$OUT/scale_$g.log" | awk 'NR>5 {s+=$4; n++} END {printf "%.0f env-steps/s over %d iterations", s/n, n}')"
done | tee "$OUT/scale.txt"
left=$((DEADLINE - START - SECONDS - 30))
echo "time-to-skill run on 2 GPUs for $left s"
timeout -s TERM -k 20 "$left" torchrun --standalone --nproc_per_node=2 train.py --terrain complex --num_envs "$ENVS" \
  --max_iterations 100000 --seed 1 --save_interval 20 --log_dir /root/tts --experiment complex_2gpu > "$OUT/tts_2gpu.log" 2>&1
echo "exit $?" >> "$OUT/tts_2gpu.log"
run=$(ls -d /root/tts/complex_2gpu/*/ | tail -1)
tar czf "$OUT/run_tts_2gpu.tgz" -C "$run" config.json $(cd "$run" && ls events.* && ls -v model_*.pt | tail -1)
grep -E '^iteration |success_rate' "$OUT/tts_2gpu.log" | tail -6
