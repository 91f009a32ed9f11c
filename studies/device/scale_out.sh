#!/bin/bash
# The scale-out measurements (studies/scale_out: `python studies/scale_out/scale_out.py`), on one host of 4 GPUs
# (nvidia-h100-x4), one subcommand per device call, after the wheel chunks and `gpu.sh install`
# (studies/device/README.md, "Scale-out"):
#
#   bash studies/device/scale_out.sh all                   # in the background: bench, then train, then eval
#                                                          # ($STAGES: those named, e.g. "train eval")
#   bash studies/device/scale_out.sh wait SECONDS          # until the background queue ends (at most SECONDS)
#   bash studies/device/scale_out.sh pack                  # bench JSONs, runs, evaluations, commands -> $OUT
#
#   bash studies/device/scale_out.sh bench                 # hexnewton-bench --task complex --mode train at each
#        # GPU count of $GPU_COUNTS (default "1 2 4") x each of $BENCH_ENVS envs per GPU (default "4096 16384"),
#        # one after another, under torchrun from 2 GPUs on ($BENCH_MODES: default train; $BENCH_ITERATIONS: 10)
#   bash studies/device/scale_out.sh train                 # the time-to-skill runs of $ROUNDS: rounds separated by
#        # "|", each a set of NAME:GPUS:ENVS_PER_GPU[:SCALINGS] run at once; the next round starts when the round
#        # ends; SCALINGS (comma-separated, e.g. iterations or mini_batches,iterations) -> --agent.scale_with_ranks
#   bash studies/device/scale_out.sh eval                  # each run's result on $ROUNDS_PER_TERRAIN (1000) unseen
#        # rounds of each of $TERRAINS (rugged stepped complex): one evaluate job per run and terrain, all at once,
#        # spread over the GPUs
#
# A run is `python train.py --task complex --num_envs ENVS_PER_GPU` on one GPU and `torchrun --standalone
# --nproc_per_node=K train.py --task complex --num_envs ENVS_PER_GPU` on K, CUDA_VISIBLE_DEVICES=GPUS; the shell's
# seconds from its launch to its exit land in $RUNS/NAME.wall. Every command run is appended to $RUNS/commands.txt.
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1   # device docs: no NVLink multicast
OUT=${OUT:-out}
RUNS=${RUNS:-/root/scale_out}
GPU_COUNTS=${GPU_COUNTS:-1 2 4}
BENCH_ENVS=${BENCH_ENVS:-4096 16384}
BENCH_MODES=${BENCH_MODES:-train}
BENCH_ITERATIONS=${BENCH_ITERATIONS:-10}
# same envs per GPU (4096) and same total envs (4096) at 1, 2 and 4 GPUs; the 1-GPU run first and alone
ROUNDS=${ROUNDS:-g1x4096:0:4096 | g4x4096:0,1,2,3:4096 | g2x4096:0,1:4096 g2x2048:2,3:2048 | g4x1024:0,1,2,3:1024}
ROUNDS_PER_TERRAIN=${ROUNDS_PER_TERRAIN:-1000}
TERRAINS=${TERRAINS:-rugged stepped complex}
# more flags for each command (a CPU smoke test: "--device cpu ..."; none on the GPU machine)
BENCH_ARGS=${BENCH_ARGS:-} TRAIN_ARGS=${TRAIN_ARGS:-} EVAL_ARGS=${EVAL_ARGS:-}
mkdir -p "$OUT" "$RUNS"
cmd=${1:-}; shift || true
log_cmd() { echo "$*" >> "$RUNS/commands.txt"; echo "$(date +%T) $*"; }
ngpu() { echo $(( $(echo "$1" | tr -cd , | wc -c) + 1 )); }
case "$cmd" in
all)
  stages=${STAGES:-bench train eval}
  nohup setsid bash -c "for s in $stages; do bash $0 \$s; done; echo queue ended" >> "$RUNS/queue.log" 2>&1 \
    < /dev/null &
  echo "started: $stages (log $RUNS/queue.log)"
  ;;
bench)
  for k in $GPU_COUNTS; do
    gpus=$(seq -s, 0 $((k - 1)))
    args="--task complex --mode $BENCH_MODES --num_envs $BENCH_ENVS --train_iterations $BENCH_ITERATIONS $BENCH_ARGS"
    if [ "$k" = 1 ]; then
      run="python -m hexnewton.apps.bench $args --json $RUNS/bench_1gpu.json"
    else
      base=""; [ -f "$RUNS/bench_1gpu.json" ] && base="--baseline $RUNS/bench_1gpu.json"
      run="torchrun --standalone --nproc_per_node=$k -m hexnewton.apps.bench $args $base --json $RUNS/bench_${k}gpu.json"
    fi
    log_cmd "CUDA_VISIBLE_DEVICES=$gpus $run"
    CUDA_VISIBLE_DEVICES=$gpus $run > "$RUNS/bench_${k}gpu.log" 2>&1
    echo "exit $? ($k GPUs)"; grep -E "^\| (train|env|sim|complex) " "$RUNS/bench_${k}gpu.log"
  done
  ;;
train)
  IFS='|' read -ra rounds <<< "$ROUNDS"
  for round in "${rounds[@]}"; do
    for spec in $round; do
      IFS=: read -r name gpus envs scalings <<< "$spec"
      k=$(ngpu "$gpus")
      launch="python train.py"; [ "$k" -gt 1 ] && launch="torchrun --standalone --nproc_per_node=$k train.py"
      scale=""; [ -n "$scalings" ] && scale="--agent.scale_with_ranks ${scalings//,/ } "
      run="$launch --task complex --num_envs $envs $scale$TRAIN_ARGS --log_dir $RUNS --experiment $name"
      log_cmd "CUDA_VISIBLE_DEVICES=$gpus $run"
      ( t0=$(date +%s.%N)
        CUDA_VISIBLE_DEVICES=$gpus $run > "$RUNS/$name.log" 2>&1
        rc=$?
        awk "BEGIN {print $(date +%s.%N) - $t0}" > "$RUNS/$name.wall"
        echo "exit $rc wall $(cat "$RUNS/$name.wall") s" >> "$RUNS/$name.log" ) &
    done
    wait
    for spec in $round; do
      name=${spec%%:*}; echo "== $name: $(tail -1 "$RUNS/$name.log")"
      grep -E "from process start|^the result" "$RUNS/$name.log"
    done
  done
  ;;
eval)
  mkdir -p "$RUNS/evals"
  gpus=$(nvidia-smi --query-gpu=index --format=csv,noheader 2>/dev/null | wc -l); [ "$gpus" -gt 0 ] || gpus=1; i=0
  for log in "$RUNS"/g*.log; do
    name=$(basename "$log" .log)
    ckpt=$(sed -n 's/^  python play.py --checkpoint //p' "$log" | tail -1)
    [ -z "$ckpt" ] && { echo "$name: no result"; continue; }
    for terrain in $TERRAINS; do
      [ -f "$RUNS/evals/${name}_$terrain/results.json" ] && continue
      run="python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint cpg_rl=$ckpt --terrains $terrain"
      run="$run --rounds $ROUNDS_PER_TERRAIN $EVAL_ARGS --out $RUNS/evals/${name}_$terrain --no-progress"
      log_cmd "CUDA_VISIBLE_DEVICES=$((i % gpus)) $run"
      ( CUDA_VISIBLE_DEVICES=$((i % gpus)) $run > "$RUNS/evals/${name}_$terrain.log" 2>&1
        echo "exit $?" >> "$RUNS/evals/${name}_$terrain.log" ) &
      i=$((i + 1))
    done
  done
  wait
  for log in "$RUNS"/evals/*.log; do echo "== $(basename "$log" .log): $(tail -1 "$log")"; done
  ;;
wait)
  limit=$1
  while [ "$SECONDS" -lt "$limit" ] && ! grep -q "^queue ended" "$RUNS/queue.log" 2>/dev/null; do sleep 5; done
  grep -vE "^(iteration|step) " "$RUNS/queue.log" | tail -30
  for log in "$RUNS"/g*.log; do
    [ -f "$log" ] && echo "-- $(basename "$log" .log): $(grep -E '^iteration [0-9]+/' "$log" | tail -1)"
  done
  ;;
pack)
  stage=$(mktemp -d); mkdir -p "$stage/runs" "$stage/evals"
  cp "$RUNS"/bench_*.json "$RUNS"/bench_*.log "$RUNS/commands.txt" "$RUNS/queue.log" "$stage/" 2>/dev/null
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader > "$stage/gpu.txt" 2>/dev/null
  for log in "$RUNS"/g*.log; do
    name=$(basename "$log" .log); run=$(ls -d "$RUNS/$name"/*/ 2>/dev/null | tail -1)
    [ -z "$run" ] && continue
    mkdir -p "$stage/runs/$name"
    cp "$run"/{timing.json,config.json} "$stage/runs/$name/" 2>/dev/null
    cp "$log" "$stage/runs/$name/train.log"; cp "$RUNS/$name.wall" "$stage/runs/$name/wall.txt" 2>/dev/null
  done
  for d in "$RUNS"/evals/*/; do
    [ -f "$d/results.json" ] && mkdir -p "$stage/evals/$(basename "$d")" && \
      cp "$d"/{results.json,report.md} "$stage/evals/$(basename "$d")/"
  done
  tar czf "$OUT/scale_out.tgz" -C "$stage" . && ls -la "$OUT/scale_out.tgz"
  ;;
*) echo "usage: see the header of $0"; exit 2 ;;
esac
