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
#   bash scripts/device/gpu.sh eval SECONDS NAME[@GPU]:ARGS...   # `python -m hexnewton.apps.evaluate ARGS` jobs at once,
#                                                                # each cut off after SECONDS -> $OUT/evals.tgz
#   bash scripts/device/gpu.sh baseline NAME [GPU] -- ARGS...   # `python -m hexnewton.apps.baselines ARGS` as train does
#   bash scripts/device/gpu.sh methods TASK MINUTES ENV_STEPS NUM_ENVS "SEEDS" "GPUS"
#        # in the background: every method ($METHODS: cpg_rl sac_cpg td3_cpg a2c_cpg joint) x seed on TASK (joint:
#        # $JOINT_TASK, default complex-joint), each run ending at ENV_STEPS env-steps or MINUTES of wall time,
#        # whichever comes first, one run per GPU at a time (equal GPUs: equal wall time); runs in $RUNS/methods/
#   bash scripts/device/gpu.sh evals ROUNDS "GPUS" TERRAIN...    # in the background: each run's last checkpoint,
#        # ROUNDS unseen rounds per terrain, one job per GPU at a time -> $RUNS/method_evals/<run>_<terrain>/
#        # ($EVAL_ARGS: more evaluate flags, e.g. --max_steps 3000)
#   bash scripts/device/gpu.sh report WHAT                      # Fig. 5a + Table 3 over seeds (hexnewton.apps.compare)
#                                                                # -> $OUT/WHAT/{report.md,results.json,fig5a.*}
#   bash scripts/device/gpu.sh busy                             # exit 0 while `methods` or `evals` jobs run
#
# Example (the complex task from its name, then 1000 test rounds per terrain, one H200):
#   bash scripts/device/gpu.sh train complex -- --task complex --num_envs 4096
#   bash scripts/device/gpu.sh wait 570 complex;  bash scripts/device/gpu.sh pack complex
#   bash scripts/device/gpu.sh eval 560 "rugged:--controllers cpg cpg_rl --checkpoint cpg_rl=/root/keep/complex.pt \
#       --terrains rugged --rounds 1000" ...
# Example (the methods of Fig. 5a and Table 3 on complex terrain, 3 seeds, 8 GPUs; 15 runs of at most 8 minutes):
#   bash scripts/device/gpu.sh methods complex 8 300000000 4096 "1 2 3" "0 1 2 3 4 5 6 7"
#   bash scripts/device/gpu.sh wait 590 _methods     # as often as needed, then
#   bash scripts/device/gpu.sh evals 1000 "0 1 2 3 4 5 6 7" rugged stepped complex
#   bash scripts/device/gpu.sh wait 590 _evals;  bash scripts/device/gpu.sh report methods_complex
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
    for name in "$@"; do pgrep -f -- "--experiment $name\b|gpu.sh $name\b" > /dev/null && busy=1; done
    [ "$busy" = 0 ] && break
    sleep 5
  done
  for name in "$@"; do
    echo "== $name"
    case $name in
      _methods) tail -4 "$RUNS/methods.log"
                for log in "$RUNS"/methods/*.log; do echo "-- $(basename "$log" .log): $(grep -E '^(iteration|step) ' "$log" | tail -1)"; done ;;
      _evals) tail -4 "$RUNS/method_evals.log" ;;
      *) grep -vE '^(iteration|step) ' "$RUNS/$name.log" | tail -12; grep -E '^(iteration|step) ' "$RUNS/$name.log" | tail -2 ;;
    esac
  done
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
      CUDA_VISIBLE_DEVICES=$gpu timeout -k 10 "$limit" python -m hexnewton.apps.evaluate $args --out "$evals/$name" \
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
baseline)
  name=$1; shift; gpu=${CUDA_VISIBLE_DEVICES:-0}
  [ "${1:-}" != "--" ] && { gpu=$1; shift; }
  shift   # --
  CUDA_VISIBLE_DEVICES=$gpu nohup python -m hexnewton.apps.baselines "$@" --log_dir "$RUNS" --experiment "$name" \
    > "$RUNS/$name.log" 2>&1 &
  echo "started $name on GPU $gpu: python -m hexnewton.apps.baselines $*"
  ;;
methods)
  [ $# -eq 6 ] || { echo "usage: gpu.sh methods TASK MINUTES ENV_STEPS NUM_ENVS \"SEEDS\" \"GPUS\""; exit 2; }
  mkdir -p "$RUNS/methods"
  nohup bash "$0" _methods "$@" > "$RUNS/methods.log" 2>&1 &
  echo "queued $(for s in $5; do for m in ${METHODS:-cpg_rl sac_cpg td3_cpg a2c_cpg joint}; do echo -n "${m}_s$s "; done; done)on GPUs $6"
  ;;
_methods)   # the queue behind `methods`
  task=$1 minutes=$2 steps=$3 envs=$4 seeds=$5 gpus=$6
  per_it=${STEPS_PER_ENV:-24}; its=$(( (steps + envs * per_it - 1) / (envs * per_it) ))
  dest="$RUNS/methods"
  jobs=(); for s in $seeds; do for m in ${METHODS:-cpg_rl sac_cpg td3_cpg a2c_cpg joint}; do jobs+=("$m $s"); done; done
  declare -A pid
  for job in "${jobs[@]}"; do
    set -- $job; m=$1 s=$2 free=
    while [ -z "$free" ]; do
      for g in $gpus; do p=${pid[$g]:-}; { [ -z "$p" ] || ! kill -0 "$p" 2>/dev/null; } && { free=$g; break; }; done
      [ -z "$free" ] && sleep 5
    done
    name=${m}_s$s
    case $m in
      cpg_rl) cmd=(python train.py --task "$task" --max_iterations "$its" --agent.max_minutes "$minutes") ;;
      joint)  cmd=(python train.py --task "${JOINT_TASK:-complex-joint}" --max_iterations "$its" --agent.max_minutes "$minutes") ;;
      *_cpg)  cmd=(python -m hexnewton.apps.baselines --task "$task" --algo "${m%_cpg}" --total_steps "$steps" --max_minutes "$minutes") ;;
      *) echo "unknown method $m"; continue ;;
    esac
    echo "$(date +%T) $name on GPU $free: ${cmd[*]}"
    CUDA_VISIBLE_DEVICES=$free "${cmd[@]}" --seed "$s" --num_envs "$envs" --log_dir "$dest" --experiment "$name" \
      > "$dest/$name.log" 2>&1 &
    pid[$free]=$!
  done
  wait
  echo "$(date +%T) all runs ended"
  ;;
evals)
  [ $# -ge 3 ] || { echo "usage: gpu.sh evals ROUNDS \"GPUS\" TERRAIN..."; exit 2; }
  mkdir -p "$RUNS/method_evals"
  nohup bash "$0" _evals "$@" > "$RUNS/method_evals.log" 2>&1 &
  echo "queued the evaluations of $(ls -d "$RUNS"/methods/*_s*/ 2>/dev/null | wc -l) runs on $3..."
  ;;
_evals)   # the queue behind `evals`
  rounds=$1 gpus=$2; shift 2
  dest="$RUNS/method_evals"
  declare -A pid
  for exp in "$RUNS"/methods/*_s*/; do
    name=$(basename "$exp"); m=${name%_s*}
    run=$(ls -d "$exp"*/ | tail -1); ck=$(ls -v "$run"model_[0-9]*.pt 2>/dev/null | tail -1)
    [ -z "$ck" ] && { echo "no checkpoint in $exp"; continue; }
    for terrain in "$@"; do
      [ -e "$dest/${name}_$terrain" ] && continue
      free=
      while [ -z "$free" ]; do
        for g in $gpus; do p=${pid[$g]:-}; { [ -z "$p" ] || ! kill -0 "$p" 2>/dev/null; } && { free=$g; break; }; done
        [ -z "$free" ] && sleep 5
      done
      echo "$(date +%T) ${name}_$terrain on GPU $free: $ck"
      CUDA_VISIBLE_DEVICES=$free python -m hexnewton.apps.evaluate --controllers "$m" --checkpoint "$m=$ck" \
        --terrains "$terrain" --rounds "$rounds" --out "$dest/${name}_$terrain" --no-progress ${EVAL_ARGS:-} \
        > "$dest/${name}_$terrain.log" 2>&1 &
      pid[$free]=$!
    done
  done
  wait
  echo "$(date +%T) all evaluations ended"
  ;;
report)
  what=$1
  python -m hexnewton.apps.compare --runs "$RUNS/methods" --evals "$RUNS/method_evals" --out "$OUT/$what" \
    && tail -n +1 "$OUT/$what/report.md" | head -60
  ;;
busy)
  pgrep -f -- "gpu.sh _(methods|evals)" > /dev/null
  ;;
*)
  sed -n '2,36p' "$0"; exit 2
  ;;
esac
