#!/bin/bash
# Train several CPG_RL runs concurrently on one GPU until a wall-clock deadline, then pack each run
# (TensorBoard events, config, last checkpoint, policy.onnx, train log) into $OUT/run_<name>.tgz.
#
#   DEADLINE_S=540 bash scripts/device/train_runs.sh "flat:--terrain flat" "rugged:--terrain rugged" ...
#
# Each argument is NAME[@GPU]:TRAIN_ARGS (@GPU pins the run to that GPU of a multi-GPU machine). With KEEP set,
# each run's last checkpoint is also copied to $KEEP/<name>.pt for later calls on the same warm machine.
# The first run compiles every kernel alone (2 iterations) so that the
# concurrent runs load them from Warp's cache (SKIP_WARMUP=1 when the cache is warm). With EVAL_STEPS set,
# each run's last checkpoint is then evaluated deterministically by play.py on its training terrain
# (EVAL_ENVS robots, start yaw noise 0.2 rad as in training, an unseen terrain/reset seed).
# Used for RESULTS.md (issue 4) on the device tool's H100.
set -u
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
left=$((DEADLINE - START - SECONDS - 45))   # 45 s for saving, ONNX export and packing
minutes=$(python -c "print(max(0.5, $left / 60))")
echo "training ${#@} runs concurrently for $minutes min"
gpu_of() { case "$1" in *@*) echo "${1#*@}";; *) echo "${CUDA_VISIBLE_DEVICES:-0}";; esac; }
for spec in "$@"; do
  name=${spec%%:*}; args=${spec#*:}; gpu=$(gpu_of "$name"); name=${name%@*}
  CUDA_VISIBLE_DEVICES=$gpu python train.py $args --max_iterations 100000 --max_minutes "$minutes" --save_interval 100 \
    --log_dir "$OUT/logs" --experiment "$name" > "$OUT/logs/$name.log" 2>&1 &
done
wait
last_of() { ls -v "$(ls -d "$OUT/logs/$1"/*/ | tail -1)"/model_*.pt | tail -1; }
for spec in "$@"; do   # evaluations run at once, each on its run's GPU
  name=${spec%%:*}; args=${spec#*:}; gpu=$(gpu_of "$name"); name=${name%@*}; last=$(last_of "$name")
  echo "== $name: $(grep -E '^(trained|stopped|last episodes)' "$OUT/logs/$name.log" | tr '\n' ' ')"
  if [ -n "${EVAL_STEPS:-}" ]; then
    terrain=$(echo "$args" | sed -n 's/.*--terrain \([a-z]*\).*/\1/p')
    CUDA_VISIBLE_DEVICES=$gpu python play.py --controller cpg_rl --checkpoint "$last" --terrain "${terrain:-flat}" \
      --num_envs "${EVAL_ENVS:-1024}" --steps "$EVAL_STEPS" --reset_yaw 0.2 --seed 11 --no-progress 2>&1 \
      | grep -A1 '^\[' > "$(dirname "$last")/eval.txt" &
  fi
done
wait
for spec in "$@"; do
  name=${spec%%:*}; name=${name%@*}; last=$(last_of "$name"); run=$(dirname "$last")
  [ -f "$run/eval.txt" ] && echo "== $name eval:" && cat "$run/eval.txt"
  [ -n "${KEEP:-}" ] && mkdir -p "$KEEP" && cp "$last" "$KEEP/$name.pt"
  tar czf "$OUT/run_$name.tgz" -C "$OUT/logs" "$name.log" -C "$OUT/logs/$name" \
    "$(basename "$run")/config.json" "$(basename "$run")/policy.onnx" "$(basename "$run")/$(basename "$last")" \
    $(cd "$OUT/logs/$name" && ls "$(basename "$run")"/eval.txt 2>/dev/null) \
    $(cd "$OUT/logs/$name" && ls "$(basename "$run")"/events.*)
done
rm -rf "$OUT/logs"
