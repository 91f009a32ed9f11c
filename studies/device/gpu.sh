#!/bin/bash
# One script for the device tool's GPU machines (studies/device/README.md): one subcommand per device call.
#
#   bash studies/device/gpu.sh install                       # after the chunk calls: wheels into /opt/site, the
#                                                            # Warp kernel cache (/root/wc.tgz) into ~/.cache
#   bash studies/device/gpu.sh train NAME [GPU] -- ARGS...   # `python train.py ARGS` in the background (setsid:
#                                                            # it outlives the call), log in $RUNS/NAME.log,
#                                                            # run directory $RUNS/NAME/; returns once the run is
#                                                            # past its imports; refuses a NAME that is running
#                                                            # (start_run below; `baseline` alike)
#   bash studies/device/gpu.sh wait SECONDS NAME...          # until those runs end (at most SECONDS), their progress
#   bash studies/device/gpu.sh pack NAME...                  # config, events, log, the result (else the last
#                                                            # checkpoint; both with PACK_LAST=1) and best ->
#                                                            # $OUT/run_NAME.tgz; the shipped checkpoint -> $KEEP/NAME.pt
#   bash studies/device/gpu.sh eval SECONDS NAME[@GPU]:ARGS...   # `python -m hexnewton.apps.evaluate ARGS` jobs at once,
#                                                                # each cut off after SECONDS -> $OUT/evals.tgz
#   bash studies/device/gpu.sh baseline NAME [GPU] -- ARGS...   # `python -m hexnewton.apps.baselines ARGS` as train does
#   bash studies/device/gpu.sh methods TASK MINUTES ENV_STEPS NUM_ENVS "SEEDS" "GPUS"
#        # in the background: every method ($METHODS: cpg_rl sac_cpg td3_cpg a2c_cpg joint; also paper: CPG_RL with
#        # task paper) x seed on TASK (joint: $JOINT_TASK, default complex-joint), or the runs $JOBS names
#        # ("cpg_rl:1 paper:1 ..."; joint_staged: task complex-joint-staged), each run ending at ENV_STEPS env-steps or
#        # MINUTES of wall time, whichever comes first, one run per word of GPUS at a time ("0 1": one per GPU, equal
#        # wall time; "0 0": two at a time on GPU 0); runs in $RUNS/methods/, NAME.done when a run
#        # ends well (finished runs are skipped); none starts after $DEADLINE (seconds since the epoch);
#        # $EVALS_AFTER="ROUNDS TERRAIN...": a GPU with no more runs starts `evals ROUNDS GPU TERRAIN...` at once
#   bash studies/device/gpu.sh evals ROUNDS "GPUS" TERRAIN...    # in the background: the fixed CPG, then each
#        # finished run's last checkpoint with its deterministic action, then with its sampled one, ROUNDS unseen
#        # rounds per terrain, $PER_GPU jobs per GPU at a time (default 3), each cut off after $EVAL_TIMEOUT s ->
#        # $RUNS/method_evals/<run>_<terrain>[_sampled]/ (done ones are skipped; $EVAL_ARGS: more evaluate flags);
#        # runs finishing meanwhile are taken too: the queue ends when nothing is left and no `methods` queue runs
#        # (both queues look for free slots and finished runs every $POLL_S seconds: 5, 2 and 10 by default)
#   bash studies/device/gpu.sh study DIR                        # a kept study's finished runs and evaluations into
#        # $RUNS (studies/paper_comparison): the queues skip what is finished
#   bash studies/device/gpu.sh collect                          # every finished run (policy, config, events, log)
#        # -> $OUT/methods_runs.tgz.NN (15 MB parts) and the evaluations -> $OUT/method_evals.tgz
#   bash studies/device/gpu.sh report WHAT                      # Fig. 5a + Table 3 over seeds (studies/paper_comparison/compare.py)
#                                                                # -> $OUT/WHAT/{report.md,results.json,fig5a.*}
#   bash studies/device/gpu.sh busy                             # exit 0 while `methods` or `evals` jobs run
#   bash studies/device/gpu.sh queue FILE [FILE ...]            # the FILEs (bash) in turn in the background, detached
#        # (setsid), from this folder: a lease's whole work in one queue, log in $QUEUE/log (default /root/queue)
#   bash studies/device/gpu.sh poll SECONDS [PATH...]           # exit 3 at once where no queue was started (the call
#        # landed on a fresh machine: the queue is lost); else until it ends (at most SECONDS), its log's last
#        # $TAIL lines (30), then each PATH copied into $OUT (a quoted glob, '/root/cand/*', is expanded then)
#
# Example (the complex task from its name, then 1000 test rounds per terrain, one H200):
#   bash studies/device/gpu.sh train complex -- --task complex --num_envs 4096
#   bash studies/device/gpu.sh wait 570 complex;  bash studies/device/gpu.sh pack complex
#   bash studies/device/gpu.sh eval 560 "rugged:--controllers cpg cpg_rl --checkpoint cpg_rl=/root/keep/complex.pt \
#       --terrains rugged --rounds 1000" ...
# Example (the paper's comparison, kept in studies/paper_comparison across leases: studies/device/README.md):
#   bash studies/device/gpu.sh study studies/paper_comparison
#   DEADLINE=$(( $(date +%s) + 840 )) JOBS="sac_cpg:1 td3_cpg:1" \
#       bash studies/device/gpu.sh methods complex 20 60000000 4096 "" "0 1"
#   bash studies/device/gpu.sh wait 590 _methods     # as often as needed, then
#   bash studies/device/gpu.sh collect               # here: python studies/paper_comparison/compare.py --study ... --add ...
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1   # device docs: no NVLink multicast
OUT=${OUT:-out}
RUNS=${RUNS:-/root/runs}
KEEP=${KEEP:-/root/keep}
mkdir -p "$OUT" "$RUNS" "$KEEP"
cmd=${1:-}; shift || true
run_dir() { ls -d "$RUNS/$1"/*/ 2>/dev/null | tail -1; }
# start_run NAME GPU COMMAND...: COMMAND --log_dir $RUNS --experiment NAME on GPU, log in $RUNS/NAME.log, detached
# (setsid: it outlives this device call); refuses a NAME that is running (a second run would overwrite its log) and
# returns once the run has printed its first line ("training ..."), past its imports: the next device call replaces
# the working tree
start_run() {
  local name=$1 gpu=$2; shift 2
  if pgrep -f -- "--experiment $name\b" > /dev/null; then
    echo "gpu.sh: a run named $name is running already (a second one would overwrite its log)" >&2; exit 1
  fi
  CUDA_VISIBLE_DEVICES=$gpu nohup setsid "$@" --log_dir "$RUNS" --experiment "$name" > "$RUNS/$name.log" 2>&1 \
    < /dev/null &
  for _ in $(seq 90); do
    grep -q "^training " "$RUNS/$name.log" 2>/dev/null && break
    pgrep -f -- "--experiment $name\b" > /dev/null || break
    sleep 1
  done
  echo "started $name on GPU $gpu: $*"
}
case "$cmd" in
install)
  bash "$(ls .dw*/install.sh | tail -1)"
  [ -f /root/wc.tgz ] && mkdir -p /root/.cache && tar xzf /root/wc.tgz -C /root/.cache
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"
  ;;
train)
  name=$1; shift; gpu=${CUDA_VISIBLE_DEVICES:-0}
  [ "${1:-}" != "--" ] && { gpu=$1; shift; }
  shift   # --
  start_run "$name" "$gpu" python train.py "$@"
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
    # the result (model_result.pt) where train.py chose one, else the last checkpoint; the last too with PACK_LAST=1
    # (to resume): a checkpoint is ~5 MB and a device call brings back ~64 MB
    keep=$last; [ -n "$final" ] && [ -f "$final" ] && keep=$final
    cp "$keep" "$KEEP/$name.pt"
    tar czf "$OUT/run_$name.tgz" -C "$RUNS" "$name.log" -C "$RUNS/$name" $(cd "$RUNS/$name" && \
      ls "$(basename "$run")"/{config.json,policy.onnx,events.*} "$(basename "$run")/$(basename "$keep")" 2>/dev/null; \
      [ -f "$best" ] && echo "$(basename "$run")/model_best.pt"
      [ "${PACK_LAST:-0}" = 1 ] && [ "$keep" != "$last" ] && echo "$(basename "$run")/$(basename "$last")")
    echo "packed $name: $(basename "$keep") kept as $KEEP/$name.pt"
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
  start_run "$name" "$gpu" python -m hexnewton.apps.baselines "$@"
  ;;
methods)
  [ $# -eq 6 ] || { echo "usage: gpu.sh methods TASK MINUTES ENV_STEPS NUM_ENVS \"SEEDS\" \"GPUS\""; exit 2; }
  mkdir -p "$RUNS/methods"
  # the queue runs from its own copy of the tree: a later call's tree (edited meanwhile) does not change its runs
  code=$RUNS/code_$(date +%s); mkdir -p "$code"
  tar --exclude='./.dw*' --exclude=./runs --exclude=./.git -cf - . | tar -xf - -C "$code"
  (cd "$code" && nohup setsid bash studies/device/gpu.sh _methods "$@" >> "$RUNS/methods.log" 2>&1 < /dev/null &)
  echo "queued $(for s in $5; do for m in ${METHODS:-cpg_rl sac_cpg td3_cpg a2c_cpg joint}; do echo -n "${m}_s$s "; done; done)on GPUs $6"
  ;;
_methods)   # the queue behind `methods`
  task=$1 minutes=$2 steps=$3 envs=$4 seeds=$5 gpus=$6
  per_it=${STEPS_PER_ENV:-24}; its=$(( (steps + envs * per_it - 1) / (envs * per_it) ))
  dest="$RUNS/methods"
  jobs=(); for s in $seeds; do for m in ${METHODS:-cpg_rl sac_cpg td3_cpg a2c_cpg joint}; do jobs+=("$m $s"); done; done
  [ -n "${JOBS:-}" ] && { jobs=(); for j in $JOBS; do jobs+=("${j%:*} ${j#*:}"); done; }   # JOBS="cpg_rl:1 joint:2 ..."
  # one slot per word of GPUS: "0 0" runs two at a time on GPU 0
  slots=($gpus); declare -A pid
  for job in "${jobs[@]}"; do
    set -- $job; m=$1 s=$2 free= slot=
    name=${m}_s$s
    # finished runs are skipped (NAME.done: this lease's, or an earlier lease's copied in by `gpu.sh study`); a run
    # cut off starts again
    [ -f "$dest/$name.done" ] && { echo "$(date +%T) $name finished: skipped"; continue; }
    while [ -z "$free" ]; do
      for i in "${!slots[@]}"; do p=${pid[$i]:-}; { [ -z "$p" ] || ! kill -0 "$p" 2>/dev/null; } && { free=${slots[$i]}; slot=$i; break; }; done
      [ -z "$free" ] && sleep "${POLL_S:-5}"
    done
    # no run starts past the deadline ($DEADLINE: seconds since the epoch), so the lease ends with whole runs
    [ -n "${DEADLINE:-}" ] && [ "$(date +%s)" -gt "$DEADLINE" ] && { echo "$(date +%T) deadline: $name not started"; continue; }
    case $m in
      cpg_rl) cmd=(python train.py --task "$task" --max_iterations "$its" --agent.max_minutes "$minutes") ;;
      paper)  cmd=(python train.py --task paper --max_iterations "$its" --agent.max_minutes "$minutes") ;;
      joint)  cmd=(python train.py --task "${JOINT_TASK:-complex-joint}" --max_iterations "$its" --agent.max_minutes "$minutes") ;;
      joint_staged) cmd=(python train.py --task complex-joint-staged --max_iterations "$its" --agent.max_minutes "$minutes") ;;
      *_cpg)  cmd=(python -m hexnewton.apps.baselines --task "$task" --algo "${m%_cpg}" --total_steps "$steps" --max_minutes "$minutes") ;;
      *) echo "unknown method $m"; continue ;;
    esac
    rm -rf "$dest/$name"
    echo "$(date +%T) $name on GPU $free: ${cmd[*]}"
    gpu_name=$(nvidia-smi -i "$free" --query-gpu=name --format=csv,noheader)
    ( t=$SECONDS
      CUDA_VISIBLE_DEVICES=$free "${cmd[@]}" --seed "$s" --num_envs "$envs" --log_dir "$dest" --experiment "$name" \
        > "$dest/$name.log" 2>&1
      rc=$?; [ $rc = 0 ] && printf '{"exit": 0, "process_s": %d, "gpu": "%s", "command": "%s"}\n' \
        $((SECONDS - t)) "$gpu_name" "${cmd[*]} --seed $s --num_envs $envs" > "$dest/$name.done"
      echo "$(date +%T) $name ended: exit $rc after $((SECONDS - t)) s" ) &
    pid[$slot]=$!
  done
  # $EVALS_AFTER="ROUNDS TERRAIN...": each GPU starts an evaluation queue (`evals`) as soon as its last run ends
  if [ -n "${EVALS_AFTER:-}" ]; then
    set -- $EVALS_AFTER; rounds=$1; shift
    for i in "${!slots[@]}"; do
      g=${slots[$i]}
      ( p=${pid[$i]:-}; while [ -n "$p" ] && kill -0 "$p" 2>/dev/null; do sleep "${POLL_S:-5}"; done
        echo "$(date +%T) GPU $g: no more runs, evaluations"; bash "$0" evals "$rounds" "$g" "$@" ) &
    done
  fi
  wait
  echo "$(date +%T) all runs ended"
  ;;
study)   # a study kept on main (studies/paper_comparison): its finished runs and evaluations into $RUNS, so that the
         # queues skip them and evaluate the runs' stored policies
  dir=${1:?usage: gpu.sh study DIR}
  mkdir -p "$RUNS/methods" "$RUNS/method_evals"
  [ -d "$dir/runs" ] && cp -rn "$dir/runs/." "$RUNS/methods/" && (cd "$dir/runs" && ls *.done) >> "$RUNS/methods/.kept"
  [ -d "$dir/evals" ] && cp -rn "$dir/evals/." "$RUNS/method_evals/"
  echo "from $dir: $(ls "$RUNS"/methods/*.done 2>/dev/null | wc -l) finished runs, $(ls "$RUNS"/method_evals/*/results.json 2>/dev/null | wc -l) evaluations"
  ;;
collect)   # the finished runs (config, events, log, last checkpoint, .done) -> $OUT/methods_runs.tgz.NN (15 MB parts)
  cd "$RUNS/methods" || exit 1
  files=()
  for done in *.done; do
    grep -qx "$done" .kept 2>/dev/null && continue   # already in the kept study
    name=${done%.done}; run=$(ls -d "$name"/*/ | tail -1); last=$(ls -v "$run"model_*[0-9].pt | tail -1)
    files+=("$done" "$name.log" "$run"config.json "$run"events.* "$last")
  done
  [ -d "$RUNS/method_evals" ] && tar czf "$OUT/method_evals.tgz" -C "$RUNS" method_evals
  [ ${#files[@]} -gt 0 ] || { echo "no new finished runs"; exit 0; }
  tar czf - "${files[@]}" | split -b 15M -d - "$OUT/methods_runs.tgz."
  ls -la "$OUT"; echo "${#files[@]} files of the new finished runs"
  ;;
evals)
  [ $# -ge 3 ] || { echo "usage: gpu.sh evals ROUNDS \"GPUS\" TERRAIN..."; exit 2; }
  mkdir -p "$RUNS/method_evals"
  nohup setsid bash "$0" _evals "$@" >> "$RUNS/method_evals.log" 2>&1 < /dev/null &
  echo "queued the evaluations of $(ls -d "$RUNS"/methods/*_s*/ 2>/dev/null | wc -l) runs on $3..."
  ;;
_evals)   # the queue behind `evals`
  rounds=$1 gpus=$2; shift 2; terrains=("$@")
  dest="$RUNS/method_evals"
  # evaluations are launch-bound: $PER_GPU jobs share a GPU (default 3)
  slots=(); for g in $gpus; do for k in $(seq "${PER_GPU:-3}"); do slots+=("$g"); done; done
  declare -A pid
  # the runs are scanned again after every pass: runs of a `methods` queue still going are evaluated as they finish;
  # the queue ends when a pass starts nothing and no `methods` queue runs
  final=0
  while :; do
    started=0
    sampled=(); specs=()   # "NAME CONTROLLER CHECKPOINT TERRAIN FLAGS": every finished run, deterministic and sampled, and the fixed CPG
    # the fixed CPG ($FIXED_CPG, default both): cpg at its default 10 ms frame (the paper's setting), cpg_frame20 on
    # the policies' physics (20 ms frame, 4 substeps); FLAGS are evaluate's flags with commas for spaces
    for terrain in "${terrains[@]}"; do
      for f in ${FIXED_CPG:-cpg cpg_frame20}; do
        case $f in
          cpg) specs+=("cpg_s0_$terrain cpg - $terrain -") ;;
          cpg_frame20) specs+=("cpg_frame20_s0_$terrain cpg - $terrain --env.sim.frame_dt,0.02,--env.sim.substeps,4") ;;
        esac
      done
    done
    for done in "$RUNS"/methods/*.done; do
      [ -e "$done" ] || continue
      name=$(basename "$done" .done); m=${name%_s*}; ctrl=$m
      case $m in paper) ctrl=cpg_rl ;; joint_staged) ctrl=joint ;; esac   # compare.CONTROLLER
      run=$(ls -d "$RUNS/methods/$name"/*/ | tail -1); ck=$(ls -v "$run"model_*[0-9].pt 2>/dev/null | tail -1)
      [ -z "$ck" ] && { echo "no checkpoint in $run"; continue; }
      for terrain in "${terrains[@]}"; do
        specs+=("${name}_$terrain $ctrl $ck $terrain -")
        # TD3's actor is deterministic: no sampled action to evaluate (compare.DETERMINISTIC_ONLY)
        [ "$m" != td3_cpg ] && sampled+=("${name}_${terrain}_sampled $ctrl $ck $terrain --stochastic")
      done
    done
    specs+=("${sampled[@]}")   # every deterministic evaluation first, then the sampled ones
    for spec in "${specs[@]}"; do
      set -- $spec; out=$1 ctrl=$2 ck=$3 terrain=$4 flags=$5
      [ -f "$dest/$out/results.json" ] && continue
      # a job is claimed before it waits for a slot, so queues started on other GPUs meanwhile take the next ones
      mkdir "$dest/$out.claim" 2>/dev/null || continue
      started=1
      rm -rf "$dest/$out"; free=
      while [ -z "$free" ]; do
        for i in "${!slots[@]}"; do p=${pid[$i]:-}; { [ -z "$p" ] || ! kill -0 "$p" 2>/dev/null; } && { free=$i; break; }; done
        [ -z "$free" ] && sleep "${POLL_S:-2}"
      done
      args=(--controllers "$ctrl" --terrains "$terrain" --rounds "$rounds" --out "$dest/$out" --no-progress)
      [ "$ck" != - ] && args+=(--checkpoint "$ctrl=$ck")
      [ "$flags" != - ] && args+=(${flags//,/ })
      echo "$(date +%T) $out on GPU ${slots[$free]}: ${args[*]}"
      ( CUDA_VISIBLE_DEVICES=${slots[$free]} timeout -k 10 "${EVAL_TIMEOUT:-3000}" python -m hexnewton.apps.evaluate "${args[@]}" ${EVAL_ARGS:-} \
          > "$dest/$out.log" 2>&1; echo "$(date +%T) $out ended: exit $?" ) &
      pid[$free]=$!
    done
    [ "$started" = 1 ] && continue
    [ "$final" = 1 ] && break
    # one more pass once no `methods` queue runs: its last runs may have finished since this pass began
    pgrep -f -- "gpu.sh _methods" > /dev/null || final=1
    sleep "${POLL_S:-10}"
  done
  wait
  echo "$(date +%T) all evaluations ended"
  ;;
report)
  what=$1
  PYTHONPATH=$PWD:$PYTHONPATH python studies/paper_comparison/compare.py --runs "$RUNS/methods" --evals "$RUNS/method_evals" --out "$OUT/$what" \
    && tail -n +1 "$OUT/$what/report.md" | head -60
  ;;
busy)
  pgrep -f -- "gpu.sh _(methods|evals)" > /dev/null
  ;;
queue)
  q=${QUEUE:-/root/queue}
  [ $# -gt 0 ] || { echo "gpu.sh queue: no file (none given)" >&2; exit 2; }
  for file in "$@"; do [ -f "$file" ] || { echo "gpu.sh queue: no file $file" >&2; exit 2; }; done
  if [ -f "$q/pid" ] && [ ! -f "$q/ended" ]; then
    echo "gpu.sh queue: a queue is running already ($q/log)" >&2; exit 1
  fi
  # the files in turn, each run in place (it finds its neighbours from its path); the queue's exit status is the
  # last nonzero one
  script="rc=0"
  for file in "$@"; do
    file=$(cd "$(dirname "$file")" && pwd)/$(basename "$file")
    script+="; echo \"\$(date +%T) queue: $file\"; bash '$file' || rc=\$?"
  done
  mkdir -p "$q" && rm -f "$q/ended"
  nohup setsid bash -c "$script; echo \$rc > '$q/ended'" > "$q/log" 2>&1 < /dev/null &
  echo $! > "$q/pid"
  echo "started the queue $* in $PWD (log $q/log)"
  ;;
poll)
  limit=${1:?gpu.sh poll SECONDS [PATH...]}; shift; q=${QUEUE:-/root/queue}
  if [ ! -f "$q/pid" ]; then
    echo "gpu.sh poll: no queue on this machine: a fresh machine, the queue and its outputs are lost" >&2; exit 3
  fi
  t=$SECONDS
  while [ ! -f "$q/ended" ] && [ $((SECONDS - t)) -lt "$limit" ]; do sleep 5; done
  if [ -f "$q/ended" ]; then echo "the queue ended (exit $(cat "$q/ended"))"; else echo "the queue runs on"; fi
  tail -n "${TAIL:-30}" "$q/log"
  # a quoted glob is expanded here, after the wait: the call's shell would have expanded it before the files existed
  for pattern in "$@"; do
    for path in $pattern; do cp -r "$path" "$OUT/" || echo "gpu.sh poll: $path not copied" >&2; done
  done
  ;;
*)
  sed -n '2,41p' "$0"; exit 2
  ;;
esac
