#!/bin/bash
# One script for the device tool's GPU machines (scripts/device/README.md): one subcommand per device call.
#
#   bash scripts/device/gpu.sh install                       # after the chunk calls: wheels into /opt/site, the
#                                                            # Warp kernel cache (/root/wc.tgz) into ~/.cache
#   bash scripts/device/gpu.sh train NAME [GPU] -- ARGS...   # `python train.py ARGS` in the background, log in
#                                                            # $RUNS/NAME.log, run directory $RUNS/NAME/
#   bash scripts/device/gpu.sh wait SECONDS NAME...          # until those runs end (at most SECONDS), their progress
#   bash scripts/device/gpu.sh pack NAME...                  # config, events, log, best and last checkpoint ->
#                                                            # $OUT/run_NAME.tgz; the shipped checkpoint -> $KEEP/NAME.pt
#   bash scripts/device/gpu.sh eval SECONDS NAME[@GPU]:ARGS...   # `python -m hexnewton.evaluate ARGS` jobs at once,
#                                                                # each cut off after SECONDS -> $OUT/evals.tgz
#
# Example (the complex task from its name, then 1000 test rounds per terrain, one H200):
#   bash scripts/device/gpu.sh train complex -- --task complex --num_envs 4096
#   bash scripts/device/gpu.sh wait 570 complex;  bash scripts/device/gpu.sh pack complex
#   bash scripts/device/gpu.sh eval 560 "rugged:--controllers cpg cpg_rl --checkpoint cpg_rl=/root/keep/complex.pt \
#       --terrains rugged --rounds 1000" ...
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1   # device docs: no NVLink multicast
OUT=${OUT:-out}
RUNS=${RUNS:-/root/runs}
KEEP=${KEEP:-/root/keep}
mkdir -p "$OUT" "$RUNS" "$KEEP"
cmd=${1:-}; shift || true
run_dir() { ls -d "$RUNS/$1"/*/ 2>/dev/null | tail -1; }
case "$cmd" in
install)
  bash .dw3bb/install.sh
  mkdir -p /root/.cache && tar xzf /root/wc.tgz -C /root/.cache
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"
  ;;
train)
  name=$1; shift; gpu=${CUDA_VISIBLE_DEVICES:-0}
  [ "${1:-}" != "--" ] && { gpu=$1; shift; }
  shift   # --
  CUDA_VISIBLE_DEVICES=$gpu nohup python train.py "$@" --log_dir "$RUNS" --experiment "$name" \
    > "$RUNS/$name.log" 2>&1 &
  echo "started $name on GPU $gpu: python train.py $*"
  ;;
wait)
  limit=$1; shift
  while [ "$SECONDS" -lt "$limit" ]; do
    busy=0
    for name in "$@"; do pgrep -f -- "--experiment $name\b" > /dev/null && busy=1; done
    [ "$busy" = 0 ] && break
    sleep 5
  done
  for name in "$@"; do echo "== $name"; grep -v '^iteration' "$RUNS/$name.log" | tail -12; grep '^iteration' "$RUNS/$name.log" | tail -2; done
  ;;
pack)
  for name in "$@"; do
    run=$(run_dir "$name"); [ -z "$run" ] && { echo "no run $name"; continue; }
    best="$run/model_best.pt"; last=$(ls -v "$run"/model_[0-9]*.pt | tail -1)
    final=$(sed -n 's/^  python play.py --checkpoint //p' "$RUNS/$name.log" | tail -1)
    cp "${final:-$last}" "$KEEP/$name.pt"
    tar czf "$OUT/run_$name.tgz" -C "$RUNS" "$name.log" -C "$RUNS/$name" $(cd "$RUNS/$name" && \
      ls "$(basename "$run")"/{config.json,policy.onnx,events.*} "$(basename "$run")/$(basename "$last")" 2>/dev/null; \
      [ -f "$best" ] && echo "$(basename "$run")/model_best.pt")
    echo "packed $name: $(basename "${final:-$last}") kept as $KEEP/$name.pt"
  done
  ;;
eval)
  limit=$1; shift
  evals=/root/evals; mkdir -p "$evals"
  for spec in "$@"; do
    name=${spec%%:*}; args=${spec#*:}
    case "$name" in *@*) gpu=${name#*@}; name=${name%@*};; *) gpu=${CUDA_VISIBLE_DEVICES:-0};; esac
    ( t=$SECONDS
      CUDA_VISIBLE_DEVICES=$gpu timeout -k 10 "$limit" python -m hexnewton.evaluate $args --out "$evals/$name" \
        --no-progress > "$evals/$name.log" 2>&1
      echo "exit $? after $((SECONDS - t)) s" >> "$evals/$name.log" ) &
  done
  wait
  tar czf "$OUT/evals.tgz" -C "$evals" .
  for spec in "$@"; do
    name=${spec%%:*}; name=${name%@*}
    echo "== $name: $(tail -1 "$evals/$name.log")"
    grep -E '^\| (flat|rugged|stepped|complex) \|' "$evals/$name/report.md" 2>/dev/null | head -8
  done
  ;;
*)
  sed -n '2,20p' "$0"; exit 2
  ;;
esac
