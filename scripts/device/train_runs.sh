#!/bin/bash
# Train several CPG_RL runs concurrently on one GPU until a wall-clock deadline, then pack each run
# (TensorBoard events, config, last checkpoint, policy.onnx, train log) into $OUT/run_<name>.tgz.
#
#   DEADLINE_S=540 bash scripts/device/train_runs.sh "flat:--terrain flat" "rugged:--terrain rugged" ...
#
# Each argument is NAME[@GPU]:TRAIN_ARGS (@GPU pins the run to that GPU of a multi-GPU machine; @0,1 runs it
# data-parallel on those GPUs through torchrun, whose ranks stop together on --max_minutes). With KEEP set,
# each run's last checkpoint and train log are also copied to $KEEP/<name>.pt / .log for later calls on the same
# warm machine (KEEP_ALL=1: every saved checkpoint too, in $KEEP/<name>/).
# The first run compiles every kernel alone (2 iterations) so that the
# concurrent runs load them from Warp's cache (SKIP_WARMUP=1 when the cache is warm). With EVAL_STEPS set,
# each run's last checkpoint is then evaluated deterministically by play.py on its training terrain
# (EVAL_ENVS robots, start yaw noise 0.2 rad as in training, an unseen terrain/reset seed), cut off after
# EVAL_TIMEOUT_S seconds (default 120; 7000 steps of 1024 robots took longer than 70 s on an H200); the
# training deadline leaves that much time. Results: $OUT/run_<name>.tgz and $OUT/eval_<name>.txt.
# Used for RESULTS.md on the device tool's GPUs.
set -u
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1   # device docs: no NVLink multicast
OUT=${OUT:-out}
START=${START_S:-0}            # seconds already spent in this call before the script started
DEADLINE=${DEADLINE_S:-540}    # end training this many seconds into the call
mkdir -p "$OUT/logs"
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"
if [ "${SKIP_WARMUP:-0}" != 1 ]; then
  t=$SECONDS
  python train.py --num_envs 4096 --terrain rugged --max_iterations 2 --log_dir /tmp/warm --experiment warm \
    > "$OUT/warmup.log" 2>&1 || { tail -40 "$OUT/warmup.log"; exit 1; }
  echo "warm-up (compile + 2 iterations): $((SECONDS - t)) s"
fi
# 45 s for saving, ONNX export and packing, plus the evaluation's time limit
eval_s=0; [ -n "${EVAL_STEPS:-}" ] && eval_s=${EVAL_TIMEOUT_S:-120}
left=$((DEADLINE - START - SECONDS - 45 - eval_s))
minutes=$(python -c "print(max(0.5, $left / 60))")
echo "training ${#@} runs concurrently for $minutes min"
gpu_of() { case "$1" in *@*) echo "${1#*@}";; *) echo "${CUDA_VISIBLE_DEVICES:-0}";; esac; }
for spec in "$@"; do
  name=${spec%%:*}; args=${spec#*:}; gpu=$(gpu_of "$name"); name=${name%@*}
  launch="python"; n=$(echo "$gpu" | tr ',' '\n' | wc -l)
  [ "$n" -gt 1 ] && launch="torchrun --standalone --nproc_per_node=$n"
  CUDA_VISIBLE_DEVICES=$gpu $launch train.py $args --max_iterations 100000 --max_minutes "$minutes" --save_interval 100 \
    --log_dir "$OUT/logs" --experiment "$name" > "$OUT/logs/$name.log" 2>&1 &
done
wait
last_of() { ls -v "$(ls -d "$OUT/logs/$1"/*/ | tail -1)"/model_*.pt | tail -1; }
# pack and keep first: a device call that runs past its limit loses everything not yet under $OUT, and
# $OUT itself is emptied by the next call
for spec in "$@"; do
  name=${spec%%:*}; name=${name%@*}; last=$(last_of "$name"); run=$(dirname "$last")
  echo "== $name: $(grep -E '^(trained|stopped|last episodes)' "$OUT/logs/$name.log" | tr '\n' ' ')"
  if [ -n "${KEEP:-}" ]; then mkdir -p "$KEEP" && cp "$last" "$KEEP/$name.pt" && cp "$OUT/logs/$name.log" "$KEEP/"; fi
  # KEEP_ALL=1: every saved checkpoint as well, for evaluating the curve (time-to-skill) in a later call
  if [ -n "${KEEP:-}" ] && [ "${KEEP_ALL:-0}" = 1 ]; then
    mkdir -p "$KEEP/$name" && cp "$run"/model_*.pt "$KEEP/$name/"
  fi
  tar czf "$OUT/run_$name.tgz" -C "$OUT/logs" "$name.log" -C "$OUT/logs/$name" \
    "$(basename "$run")/config.json" "$(basename "$run")/policy.onnx" "$(basename "$run")/$(basename "$last")" \
    $(cd "$OUT/logs/$name" && ls "$(basename "$run")"/events.*)
done
if [ -n "${EVAL_STEPS:-}" ]; then   # evaluations run at once, each on its run's GPU, within EVAL_TIMEOUT_S
  for spec in "$@"; do
    name=${spec%%:*}; args=${spec#*:}; gpu=$(gpu_of "$name"); name=${name%@*}; last=$(last_of "$name")
    terrain=$(echo "$args" | sed -n 's/.*--terrain \([a-z]*\).*/\1/p')
    CUDA_VISIBLE_DEVICES=${gpu%%,*} timeout "${EVAL_TIMEOUT_S:-120}" python play.py --controller cpg_rl --checkpoint "$last" \
      --terrain "${terrain:-flat}" --num_envs "${EVAL_ENVS:-1024}" --steps "$EVAL_STEPS" --reset_yaw 0.2 --seed 11 \
      --no-progress 2>&1 | grep -A1 '^\[' > "$OUT/eval_$name.txt" &
  done
  wait
  for spec in "$@"; do name=${spec%%:*}; name=${name%@*}; echo "== $name eval:"; cat "$OUT/eval_$name.txt"; done
fi
rm -rf "$OUT/logs"
