#!/bin/bash
# The time-to-skill measurements (studies/time_to_skill/, BENCHMARKS.md "Start-up" and "Terrain contact"), one
# subcommand per device call, after the wheel chunks and `gpu.sh install` (studies/device/README.md):
#
#   bash studies/device/time_to_skill.sh startup [ARGS...]   # `train.py --task complex ARGS` to its first
#                                                      # iterations, twice: a cold Warp kernel cache, then the warm one;
#                                                      # phase tables (ARGS given: in $OUT/startup_<ARGS>/)
#   bash studies/device/time_to_skill.sh caches        # which cache a fresh start lacks: `train.py --task complex` to
#                                                      # its first iterations three times, each with its own Warp kernel
#                                                      # cache (WARP_CACHE_PATH) and CUDA driver JIT cache
#                                                      # (CUDA_CACHE_PATH): both empty; Warp's empty, the driver's from
#                                                      # the first; Warp's from the first, the driver's empty
#                                                      # -> $OUT/caches/
#   bash studies/device/time_to_skill.sh fresh         # a fresh machine's start-up, the first CUDA program run:
#                                                      # `train.py --task complex --max_iterations 1` with empty Warp and
#                                                      # driver caches of its own, then again with both as it left them;
#                                                      # logs and timing.json (startup_notes: the modules the first step
#                                                      # loaded) -> $OUT/fresh/
#   bash studies/device/time_to_skill.sh contact       # sim-only complex and stepped at 16384 envs under each terrain
#                                                      # contact setting, the task's physics (20 ms frame, 4 substeps)
#   bash studies/device/time_to_skill.sh train NAME SEED [ARGS...]   # `python train.py --task complex --seed SEED
#                                                      # ARGS` alone, in the background, timed from its process start
#                                                      # (ARGS starting with --resume CKPT: that checkpoint's task)
#   bash studies/device/time_to_skill.sh wait SECONDS NAME...        # until those runs end
#   bash studies/device/time_to_skill.sh eval SECONDS ROUNDS NAME... # each run's result on ROUNDS test rounds per
#                                                      # terrain, with the fixed CPG, in one evaluate job per run
#   bash studies/device/time_to_skill.sh pack NAME...  # logs, timing.json, results, result checkpoints -> $OUT
#   bash studies/device/time_to_skill.sh jit           # which library makes the CUDA driver JIT-compile PTX on a
#                                                      # fresh machine: torch's arch list; a torch-only PPO step and
#                                                      # `train.py --task complex --max_iterations 3` (Warp's cache as
#                                                      # unpacked by `gpu.sh install`), each with an empty driver cache,
#                                                      # first with CUDA_DISABLE_PTX_JIT=1 (what needs the JIT fails and
#                                                      # names itself), then timed with it -> $RUNS/jit/
#   bash studies/device/time_to_skill.sh gate [ARGS...]  # in the background, on one host of 4 GPUs: seeds $SEEDS
#                                                      # (default "1 2 3") of `train.py --task $TASK --seed S ARGS`
#                                                      # ($TASK: default complex),
#                                                      # seed i alone on GPU i-1, each result then on $ROUNDS (1000) test
#                                                      # rounds per terrain on its GPU; on GPU 3 the shipped policy on
#                                                      # the same rounds and the fixed CPG on rugged ground ($JIT=1:
#                                                      # `jit` first);
#                                                      # $BENCH=1: then the scale-out bench (scale_out.sh bench);
#                                                      # $EVAL_ARGS: more evaluate flags;
#                                                      # $GPU3_AFTER: commands for GPU 3 after its evaluations
#                                                      # (outputs under $RUNS/extra/, packed by gate_wait);
#                                                      # $SEED_AFTER: commands for each seed's GPU beside its
#                                                      # evaluations ($NAME seedS, $CKPT its result; e.g.
#                                                      # studies/device/capability.sh's curves)
#   bash studies/device/time_to_skill.sh gate_wait SECONDS   # until the gate's queue ends (at most SECONDS), its log;
#                                                      # everything finished so far -> $OUT/gate.tgz (checkpoints in
#                                                      # $OUT/gate_ckpt.tgz.NN, 9 MB parts)
#
# Every output lands in $OUT/<what>/ (at most 8 files come back per call: pack what you need).
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
OUT=${OUT:-out}
RUNS=${RUNS:-/root/tts}
KEEP=${KEEP:-/root/keep}   # the gate's result checkpoints
mkdir -p "$OUT" "$RUNS"
cmd=${1:-}; shift || true
gpu_name() { nvidia-smi --query-gpu=name --format=csv,noheader | head -1; }
# run_script NAME SEED [ARGS...]: $RUNS/NAME.sh runs `python train.py --task complex --seed SEED ARGS` (ARGS starting
# with --resume CKPT: that checkpoint's task), log $RUNS/NAME.log, its last line the wall time from process start
run_script() {
  local name=$1 seed=$2; shift 2
  mkdir -p "$RUNS/$name"
  { echo 't0=$(date +%s.%N)'
    task="--task ${TASK:-complex}"; [ "${1:-}" = "--resume" ] && task=""
    printf 'python train.py %s --seed %q' "$task" "$seed"; [ $# -gt 0 ] && printf ' %q' "$@"
    printf ' --log_dir %q --experiment %q > %q 2>&1\n' "$RUNS" "$name" "$RUNS/$name.log"
    printf 'echo "exit $? wall $(awk "BEGIN {print $(date +%%s.%%N) - $t0}") s" >> %q\n' "$RUNS/$name.log"
  } > "$RUNS/$name.sh"
}
# evaluate_job NAME ARGS...: `python -m hexnewton.apps.evaluate ARGS $EVAL_ARGS` into $RUNS/eval_NAME/, log $RUNS/eval_NAME.log
evaluate_job() {
  local name=$1; shift
  timeout -k 10 "${EVAL_TIMEOUT:-1500}" python -m hexnewton.apps.evaluate "$@" ${EVAL_ARGS:-} --out "$RUNS/eval_$name" --no-progress \
    > "$RUNS/eval_$name.log" 2>&1
  echo "exit $?" >> "$RUNS/eval_$name.log"
}
# fixed_cpg_job NAME ROUNDS: the fixed CPG on ROUNDS rugged test rounds under the policy's physics (20 ms frame,
# 4 substeps), as evaluate_job
fixed_cpg_job() {
  evaluate_job "$1" --controllers cpg --terrains rugged --rounds "$2" --env.sim.frame_dt 0.02 --env.sim.substeps 4
}
result_of() { sed -n 's/^  python play.py --checkpoint //p' "$RUNS/$1.log" 2>/dev/null | tail -1; }
# cache_run WHAT NAME WARP_CACHE DRIVER_CACHE ARGS...: `train.py --task complex ARGS` with its own Warp kernel cache
# (WARP_CACHE_PATH) and CUDA driver cache (CUDA_CACHE_PATH) -> $OUT/WHAT/NAME.log (its exit, time and both caches'
# sizes appended) and $OUT/WHAT/timing_NAME.json; prints its start-up and exit lines
cache_run() {
  local what=$1 name=$2 warp=$3 driver=$4 t0; shift 4
  t0=$(date +%s.%N)
  WARP_CACHE_PATH=$warp CUDA_CACHE_PATH=$driver python train.py --task complex "$@" --log_dir "$RUNS/$what" \
    --experiment "$name" > "$OUT/$what/$name.log" 2>&1
  echo "exit $? after $(awk "BEGIN {print $(date +%s.%N) - $t0}") s (shell)" >> "$OUT/$what/$name.log"
  echo "== $name: Warp cache $(basename "$warp") ($(du -sh "$warp" 2>/dev/null | cut -f1)), driver cache" \
    "$(basename "$driver") ($(du -sh "$driver" 2>/dev/null | cut -f1))" | tee -a "$OUT/$what/$name.log"
  grep -E "^start-up|^exit" "$OUT/$what/$name.log"
  cp "$(ls -d "$RUNS/$what/$name"/*/ | tail -1)/timing.json" "$OUT/$what/timing_$name.json"
}
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
    cache_run caches "$1" "$c/$2" "$c/$3" --max_iterations 3
  done
  ;;
fresh)
  mkdir -p "$OUT/fresh"
  gpu_name > "$OUT/fresh/gpu.txt"
  c=/root/fresh_caches; rm -rf "$c"
  for run in cold warm; do
    cache_run fresh "$run" "$c/warp" "$c/driver" --max_iterations 1 --agent.validation_rounds 0
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
  run_script "$name" "$seed" "$@"
  # setsid: the run outlives this call; the shell's clock gives the wall time from process start
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
    ckpt=$(result_of "$name")
    [ -z "$ckpt" ] && { echo "$name: no result"; continue; }
    EVAL_TIMEOUT=$limit evaluate_job "$name" --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" \
      --terrains rugged stepped complex --rounds "$rounds" &
  done
  [ ! -d "$RUNS/eval_cpg" ] && EVAL_TIMEOUT=$limit fixed_cpg_job cpg "$rounds" &
  wait
  for name in "$@" cpg; do echo "== $name"; tail -1 "$RUNS/eval_$name.log"; grep -E "^\| " "$RUNS/eval_$name/report.md" 2>/dev/null | head -10; done
  ;;
pack)
  mkdir -p "$OUT/runs"
  for name in "$@"; do
    run=$(ls -d "$RUNS/$name"/*/ 2>/dev/null | tail -1)
    ckpt=$(result_of "$name")
    tar czf "$OUT/runs/$name.tgz" -C "$RUNS" "$name.log" $( [ -d "$RUNS/eval_$name" ] && echo "eval_$name" ) \
      -C "$run" config.json timing.json $(cd "$run" && ls events.* policy.onnx 2>/dev/null) \
      $( [ -n "$ckpt" ] && echo "$(basename "$ckpt")" )
    echo "packed $name ($(du -h "$OUT/runs/$name.tgz" | cut -f1))"
  done
  ;;
jit)
  d=$RUNS/jit c=/root/jit_caches; rm -rf "$d" "$c"; mkdir -p "$d" "$c"
  { gpu_name; nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -1
    python3 -c "import torch; print('torch', torch.__version__, 'cuda', torch.version.cuda, torch.cuda.get_arch_list())"
  } 2>&1 | tee "$d/versions.txt"
  # a PPO step as rsl-rl's takes it: an ELU MLP, a Beta policy's sample, log-prob and entropy, Adam
  cat > "$d/torch_step.py" <<'PY'
import time
t0 = time.time()
import torch
net = torch.nn.Sequential(torch.nn.Linear(59, 512), torch.nn.ELU(), torch.nn.Linear(512, 256), torch.nn.ELU(),
                          torch.nn.Linear(256, 30)).cuda()
opt = torch.optim.Adam(net.parameters(), lr=1e-3)
obs = torch.randn(4096, 59, device="cuda")
for _ in range(3):
    a, b = torch.nn.functional.softplus(net(obs)).add(1.0).chunk(2, dim=-1)
    dist = torch.distributions.Beta(a, b)
    x = dist.sample().clamp(1e-4, 1 - 1e-4)
    loss = -(dist.log_prob(x).sum(-1).mean() + 0.01 * dist.entropy().sum(-1).mean())
    opt.zero_grad(); loss.backward(); torch.nn.utils.clip_grad_norm_(net.parameters(), 1.0); opt.step()
torch.cuda.synchronize()
print(f"torch PPO step: {time.time() - t0:.1f} s")
PY
  # Warp's cache as `gpu.sh install` unpacked it (the kernels precompiled on the CPU machine), copied before runs add to it
  [ -d /root/.cache/warp ] && cp -r /root/.cache/warp "$c/warp_pre"
  for run in "torch_nojit torch 1" "torch_jit torch 0" "train_nojit train 1" "train_jit train 0"; do
    set -- $run
    name=$1 what=$2 nojit=$3 t0=$(date +%s.%N)
    env=(CUDA_CACHE_PATH="$c/driver_$name"); [ "$nojit" = 1 ] && env+=(CUDA_DISABLE_PTX_JIT=1)
    if [ "$what" = torch ]; then
      env "${env[@]}" timeout -k 10 300 python3 "$d/torch_step.py" > "$d/$name.log" 2>&1
    else
      rm -rf "$c/warp_$name"; cp -r "$c/warp_pre" "$c/warp_$name" 2>/dev/null || mkdir -p "$c/warp_$name"
      env "${env[@]}" WARP_CACHE_PATH="$c/warp_$name" timeout -k 10 420 python train.py --task complex \
        --max_iterations 3 --log_dir "$RUNS/jit_runs" --experiment "$name" > "$d/$name.log" 2>&1
    fi
    rc=$?
    echo "== $name: exit $rc after $(awk "BEGIN {print $(date +%s.%N) - $t0}") s, driver cache $(du -sh "$c/driver_$name" 2>/dev/null | cut -f1)" \
      | tee -a "$d/$name.log" "$d/summary.txt"
    grep -E "^start-up|Error|error|JIT|PTX" "$d/$name.log" | head -8 | tee -a "$d/summary.txt"
  done
  ;;
gate)
  # the queue runs from its own copy of the tree: the next device call replaces the working tree
  code=$RUNS/code; rm -rf "$code"; mkdir -p "$code"
  tar --exclude='./.dw*' --exclude=./runs --exclude=./.git -cf - . | tar -xf - -C "$code"
  (cd "$code" && nohup setsid bash studies/device/time_to_skill.sh _gate "$@" >> "$RUNS/gate.log" 2>&1 < /dev/null &)
  echo "started the gate queue: seeds ${SEEDS:-1 2 3}, train.py --task ${TASK:-complex} $* (log $RUNS/gate.log)"
  ;;
_gate)   # the queue behind `gate`
  rounds=${ROUNDS:-1000}
  echo "$(date +%T) gate: seeds ${SEEDS:-1 2 3}: python train.py --task ${TASK:-complex} --seed S $*;" \
    "$rounds test rounds per terrain"
  ( export CUDA_VISIBLE_DEVICES=3
    [ "${JIT:-0}" = 1 ] && { bash "$0" jit > "$RUNS/jit.log" 2>&1; echo "$(date +%T) jit ended"; }
    for t in rugged stepped complex; do
      evaluate_job "shipped_$t" --controllers cpg_rl --checkpoint cpg_rl=results/policies/cpg_rl_complex.pt \
        --terrains "$t" --rounds "$rounds" &
    done
    fixed_cpg_job cpg_rugged "$rounds" &
    wait; echo "$(date +%T) shipped and fixed CPG evaluated"
    # $GPU3_AFTER: more work for GPU 3 while the seeds train (e.g. capability curves, one evaluate per curve, each
    # with --out "$RUNS"/extra/NAME); its log in $RUNS/extra.log
    if [ -n "${GPU3_AFTER:-}" ]; then
      mkdir -p "$RUNS/extra"; RUNS=$RUNS bash -c "$GPU3_AFTER" > "$RUNS/extra.log" 2>&1
      echo "$(date +%T) GPU 3's further work ended: exit $?"
    fi ) &
  i=0
  for seed in ${SEEDS:-1 2 3}; do
    name=seed$seed
    run_script "$name" "$seed" "$@"
    ( export CUDA_VISIBLE_DEVICES=$i
      echo "$(date +%T) $name on GPU $i"
      bash "$RUNS/$name.sh"; echo "$(date +%T) $name: $(tail -1 "$RUNS/$name.log")"
      ckpt=$(result_of "$name")
      [ -z "$ckpt" ] && { echo "$name: no result"; exit 0; }
      mkdir -p "$KEEP" && cp "$ckpt" "$KEEP/$name.pt"
      for t in rugged stepped complex; do
        evaluate_job "${name}_$t" --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" --terrains "$t" --rounds "$rounds" &
      done
      if [ -n "${SEED_AFTER:-}" ]; then
        NAME=$name CKPT=$ckpt RUNS=$RUNS bash -c "$SEED_AFTER" > "$RUNS/extra_$name.log" 2>&1
        echo "$(date +%T) $name's further work ended: exit $?"
      fi
      wait; echo "$(date +%T) $name evaluated" ) &
    i=$((i + 1))
  done
  wait
  if [ "${BENCH:-0}" = 1 ]; then
    echo "$(date +%T) scale-out bench"
    RUNS=/root/scale_out bash studies/device/scale_out.sh bench
  fi
  echo "$(date +%T) gate ended"
  ;;
gate_wait)
  limit=$1
  while [ "$SECONDS" -lt "$limit" ] && ! grep -q "gate ended" "$RUNS/gate.log" 2>/dev/null; do sleep 5; done
  cat "$RUNS/gate.log"; cat "$RUNS/jit/summary.txt" 2>/dev/null
  for log in "$RUNS"/seed*.log; do
    [ -f "$log" ] && echo "-- $(basename "$log" .log): $(grep -E '^iteration [0-9]+/' "$log" | tail -1)"
  done
  for log in "$RUNS"/eval_*.log; do echo "-- $(basename "$log" .log): $(tail -1 "$log")"; done
  # everything finished so far (no checkpoints of the intermediate iterations)
  (cd "$RUNS" && tar czf "$OUT/gate.tgz" gate.log jit.log jit \
    $(ls seed*.log seed*.sh eval_*.log extra*.log commands.txt 2>/dev/null) \
    $(for d in extra/*/; do [ -f "$d/results.json" ] && echo "$d"; done) $(ls extra/*.log 2>/dev/null) \
    $(for d in eval_*/; do [ -f "$d/results.json" ] && echo "$d"; done) \
    $(for s in seed*/; do r=$(ls -d "$s"*/ 2>/dev/null | tail -1); [ -n "$r" ] && ls "$r"{config.json,timing.json,events.*,policy.onnx} 2>/dev/null; done) \
    $(ls -d /root/scale_out 2>/dev/null | sed 's|.*|../scale_out|') 2>/dev/null)
  [ -d "$KEEP" ] && tar czf - -C "$KEEP" . 2>/dev/null | split -b 9M -d - "$OUT/gate_ckpt.tgz."
  ls -la "$OUT"
  ;;
*) echo "usage: see the header of $0"; exit 2 ;;
esac
