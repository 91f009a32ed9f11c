#!/bin/bash
# The time-to-skill measurements (results/time_to_skill/, BENCHMARKS.md "Start-up" and "Terrain contact"), one
# subcommand per device call, after the wheel chunks and `gpu.sh install` (scripts/device/README.md):
#
#   bash scripts/device/time_to_skill.sh startup [ARGS...]   # `train.py --task complex ARGS` to its first
#                                                      # iterations, twice: a cold Warp kernel cache, then the warm one;
#                                                      # phase tables (ARGS given: in $OUT/startup_<ARGS>/)
#   bash scripts/device/time_to_skill.sh caches        # which cache a fresh start lacks: `train.py --task complex` to
#                                                      # its first iterations three times, each with its own Warp kernel
#                                                      # cache (WARP_CACHE_PATH) and CUDA driver JIT cache
#                                                      # (CUDA_CACHE_PATH): both empty; Warp's empty, the driver's from
#                                                      # the first; Warp's from the first, the driver's empty
#                                                      # -> $OUT/caches/
#   bash scripts/device/time_to_skill.sh contact       # sim-only complex and stepped at 16384 envs under each terrain
#                                                      # contact setting, the task's physics (20 ms frame, 4 substeps)
#   bash scripts/device/time_to_skill.sh train NAME SEED [ARGS...]   # `python train.py --task complex --seed SEED
#                                                      # ARGS` alone, in the background, timed from its process start
#                                                      # (ARGS starting with --resume CKPT: that checkpoint's task)
#   bash scripts/device/time_to_skill.sh wait SECONDS NAME...        # until those runs end
#   bash scripts/device/time_to_skill.sh eval SECONDS ROUNDS NAME... # each run's result on ROUNDS test rounds per
#                                                      # terrain, with the fixed CPG, in one evaluate job per run
#   bash scripts/device/time_to_skill.sh pack NAME...  # logs, timing.json, results, result checkpoints -> $OUT
#
# Every output lands in $OUT/<what>/ (at most 8 files come back per call: pack what you need).
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
OUT=${OUT:-out}
RUNS=${RUNS:-/root/tts}
mkdir -p "$OUT" "$RUNS"
cmd=${1:-}; shift || true
gpu_name() { nvidia-smi --query-gpu=name --format=csv,noheader | head -1; }
case "$cmd" in
startup)
  what=startup; [ $# -gt 0 ] && what="startup_$(echo "$*" | tr -c 'A-Za-z0-9.\n' _ | sed 's/^_*//')"
  mkdir -p "$OUT/$what"
  gpu_name > "$OUT/$what/gpu.txt"
  for cache in cold warm; do
    [ "$cache" = cold ] && rm -rf /root/.cache/warp
    t0=$(date +%s.%N)
    python train.py --task complex --max_iterations 3 "$@" --log_dir "$RUNS/$what" --experiment "$cache" \
      > "$OUT/$what/$cache.log" 2>&1
    echo "exit $? after $(awk "BEGIN {print $(date +%s.%N) - $t0}") s (shell)" >> "$OUT/$what/$cache.log"
    grep -E "^start-up|from process start|^exit" "$OUT/$what/$cache.log"
    cp "$(ls -d "$RUNS/$what/$cache"/*/ | tail -1)/timing.json" "$OUT/$what/timing_$cache.json"
  done
  tar czf /root/warpcache.tgz -C /root/.cache warp && ls -la /root/warpcache.tgz
  ;;
caches)
  mkdir -p "$OUT/caches"
  gpu_name > "$OUT/caches/gpu.txt"
  c=/root/caches; rm -rf "$c"
  for run in "both_empty w1 n1" "warp_empty w2 n1" "driver_empty w1 n3"; do
    set -- $run
    t0=$(date +%s.%N)
    WARP_CACHE_PATH=$c/$2 CUDA_CACHE_PATH=$c/$3 python train.py --task complex --max_iterations 3 \
      --log_dir "$RUNS/caches" --experiment "$1" > "$OUT/caches/$1.log" 2>&1
    echo "exit $? after $(awk "BEGIN {print $(date +%s.%N) - $t0}") s (shell)" >> "$OUT/caches/$1.log"
    echo "== $1: Warp cache $2 ($(du -sh $c/$2 | cut -f1)), driver cache $3 ($(du -sh $c/$3 | cut -f1))" \
      | tee -a "$OUT/caches/$1.log"
    grep -E "^start-up|^exit" "$OUT/caches/$1.log"
    cp "$(ls -d "$RUNS/caches/$1"/*/ | tail -1)/timing.json" "$OUT/caches/timing_$1.json"
  done
  ;;
contact)
  mkdir -p "$OUT/contact"
  gpu_name > "$OUT/contact/gpu.txt"
  base="--device cuda --num_envs 16384 --mode sim --frames 200 --env.sim.frame_dt 0.02 --env.sim.substeps 4"
  for setting in mesh mesh_boxes mesh_speculative mesh_boxes_speculative; do
    args="--env.terrain.collision ${setting%_speculative}"
    case $setting in *speculative) args="$args --env.sim.rigid_gap 0.002 --env.sim.terrain_gap 0 --env.sim.speculative_gap 0.01";; esac
    python -m hexnewton.apps.bench $base --terrain complex stepped $args --json "$OUT/contact/$setting.json" \
      > "$OUT/contact/$setting.log" 2>&1
    echo "== $setting ($args)"; grep -E "robot-s/s|overflow|Error" "$OUT/contact/$setting.log" | head -6
  done
  ;;
train)
  name=$1 seed=$2; shift 2
  mkdir -p "$RUNS/$name"
  # setsid: the run outlives this call; the shell's clock gives the wall time from process start
  { echo 't0=$(date +%s.%N)'
    task="--task complex"; [ "${1:-}" = "--resume" ] && task=""
    printf 'python train.py %s --seed %q' "$task" "$seed"; [ $# -gt 0 ] && printf ' %q' "$@"
    printf ' --log_dir %q --experiment %q > %q 2>&1\n' "$RUNS" "$name" "$RUNS/$name.log"
    printf 'echo "exit $? wall $(awk "BEGIN {print $(date +%%s.%%N) - $t0}") s" >> %q\n' "$RUNS/$name.log"
  } > "$RUNS/$name.sh"
  setsid bash "$RUNS/$name.sh" > /dev/null 2>&1 < /dev/null &
  echo "started $name: $(sed -n 2p "$RUNS/$name.sh")"
  ;;
wait)
  limit=$1; shift
  while [ "$SECONDS" -lt "$limit" ]; do
    busy=0
    for name in "$@"; do grep -q "^exit " "$RUNS/$name.log" 2>/dev/null || busy=1; done
    [ "$busy" = 0 ] && break
    sleep 5
  done
  for name in "$@"; do
    echo "== $name"; grep -E "^(start-up|iteration [0-9]+: curriculum|finished|best|exit|.*from process start)" \
      "$RUNS/$name.log" | tail -8; grep -E "^iteration [0-9]+/" "$RUNS/$name.log" | tail -2
  done
  ;;
eval)
  # the policy on the three terrains, and the fixed CPG on rugged ground under the policy's physics (20 ms frame,
  # 4 substeps), each an evaluate job of ROUNDS test rounds per terrain, all at once
  limit=$1 rounds=$2; shift 2
  for name in "$@"; do
    ckpt=$(sed -n 's/^  python play.py --checkpoint //p' "$RUNS/$name.log" | tail -1)
    [ -z "$ckpt" ] && { echo "$name: no result"; continue; }
    ( timeout -k 10 "$limit" python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" \
        --terrains rugged stepped complex --rounds "$rounds" --out "$RUNS/eval_$name" --no-progress \
        > "$RUNS/eval_$name.log" 2>&1; echo "exit $?" >> "$RUNS/eval_$name.log" ) &
  done
  if [ ! -d "$RUNS/eval_cpg" ]; then
    ( timeout -k 10 "$limit" python -m hexnewton.apps.evaluate --controllers cpg --terrains rugged --rounds "$rounds" \
        --env.sim.frame_dt 0.02 --env.sim.substeps 4 --out "$RUNS/eval_cpg" --no-progress > "$RUNS/eval_cpg.log" 2>&1
      echo "exit $?" >> "$RUNS/eval_cpg.log" ) &
  fi
  wait
  for name in "$@" cpg; do echo "== $name"; tail -1 "$RUNS/eval_$name.log"; grep -E "^\| " "$RUNS/eval_$name/report.md" 2>/dev/null | head -10; done
  ;;
pack)
  mkdir -p "$OUT/runs"
  for name in "$@"; do
    run=$(ls -d "$RUNS/$name"/*/ 2>/dev/null | tail -1)
    ckpt=$(sed -n 's/^  python play.py --checkpoint //p' "$RUNS/$name.log" | tail -1)
    tar czf "$OUT/runs/$name.tgz" -C "$RUNS" "$name.log" $( [ -d "$RUNS/eval_$name" ] && echo "eval_$name" ) \
      -C "$run" config.json timing.json $(cd "$run" && ls events.* policy.onnx 2>/dev/null) \
      $( [ -n "$ckpt" ] && echo "$(basename "$ckpt")" )
    echo "packed $name ($(du -h "$OUT/runs/$name.tgz" | cut -f1))"
  done
  ;;
*) echo "usage: see the header of $0"; exit 2 ;;
esac
