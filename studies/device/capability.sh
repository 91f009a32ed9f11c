#!/bin/bash
# Capability curves (studies/capability, docs/evaluation.md "Capability curves"): one policy's curves and the issue's
# named points, each an evaluate job of its own in the background on this call's GPU (CUDA_VISIBLE_DEVICES), outputs
# in $RUNS/extra/NAME_<what>/ (a job cut off keeps the others), logs beside them; after the wheel chunks and
# `gpu.sh install` (studies/device/README.md, "Capability curves"):
#
#   bash studies/device/capability.sh curves NAME CKPT [CONTROLLER...]   # the default curves (rollout.DEFAULT_SWEEPS,
#        # `evaluate --sweep CURVE --no-nominal`, each point $CURVE_ROUNDS (200) rounds on its course), one job per
#        # curve, all at once; CONTROLLER: default cpg_rl (add cpg for the fixed CPG beside)
#   bash studies/device/capability.sh points NAME CKPT   # the issue's named points, $POINT_ROUNDS (1000) rounds each:
#        # 8 cm rises and 20 cm treads (stepped), 8 cm blocks (rugged), friction 0.3, 50 % motor strength and a 1 kg
#        # payload (complex), one job per point, all at once
#   bash studies/device/capability.sh wait SECONDS NAME...   # until those jobs end (at most SECONDS), their last lines
#   bash studies/device/capability.sh curves4        # on one host of 4 GPUs, detached from the call and run from a
#        # copy of the tree ($RUNS/code): GPU 0 the shipped policy's curves with the fixed CPG beside; GPU 1 the README
#        # command (`train.py --task complex`), then its result's curves (NAME readme); GPU 2 the margin seeds 1 and 3
#        # (studies/capability/policies), GPU 3 seed 2, one after another; poll with `wait SECONDS shipped readme
#        # seed1 seed2 seed3`; $SKIP: job names not to run (curves already complete)
#   bash studies/device/capability.sh margin         # on one host of 4 GPUs, in the background: the one-command gate
#        # (time_to_skill.sh gate) of $TASK (complex-margin): seeds 1-3 on GPUs 0-2, each result's curves and named
#        # points beside its test rounds; on GPU 3 the shipped policy's test rounds, then its curves with the fixed
#        # CPG beside, the README command (`train.py --task complex`) and its result's curves; poll and bring back
#        # with `time_to_skill.sh gate_wait SECONDS`
#
# Both return once their jobs have started unless $FOREGROUND=1 (then they wait for them); at most $MAX_JOBS (default
# 6) of one call's jobs run at once, the next starting as one ends (17 evaluations on one H100 at once left most curves
# at 1-3 points after 15 minutes). $EVAL_ARGS: more flags for every evaluate (a CPU smoke test: "--device cpu
# --max_steps 20"). Every command is appended to $RUNS/commands.txt.
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
RUNS=${RUNS:-/root/tts}
CURVES=${CURVES:-step_rise tread_depth block_height friction payload motor_strength push action_delay}
mkdir -p "$RUNS/extra"
cmd=${1:-}; shift || true
# job NAME ARGS...: `python -m hexnewton.apps.evaluate ARGS --out $RUNS/extra/NAME` in the background, log beside it
job() {
  local name=$1; shift
  [ -f "$RUNS/extra/$name/results.json" ] && return 0
  case " ${SKIP:-} " in *" $name "*) return 0 ;; esac
  while [ "$(jobs -rp | wc -l)" -ge "${MAX_JOBS:-6}" ]; do sleep 2; done
  rm -rf "$RUNS/extra/$name"
  echo "CUDA_VISIBLE_DEVICES=${CUDA_VISIBLE_DEVICES:-} python -m hexnewton.apps.evaluate $* ${EVAL_ARGS:-}" \
    "--out $RUNS/extra/$name" >> "$RUNS/commands.txt"
  ( timeout -k 10 "${EVAL_TIMEOUT:-1500}" python -m hexnewton.apps.evaluate "$@" ${EVAL_ARGS:-} \
      --out "$RUNS/extra/$name" --no-progress > "$RUNS/extra/$name.log" 2>&1
    echo "exit $?" >> "$RUNS/extra/$name.log" ) &
}
# readme_queue: a script (for bash -c) of the README command, `train.py --task complex`, its console and exit in
# $RUNS/extra/readme_train.log, its result kept as $KEEP/readme.pt, then that result's curves (NAME readme)
readme_queue() {
  echo "python train.py --task complex --log_dir $RUNS/readme --experiment complex > $RUNS/extra/readme_train.log 2>&1
    echo \"exit \$?\" >> $RUNS/extra/readme_train.log
    R=\$(sed -n 's/^  python play.py --checkpoint //p' $RUNS/extra/readme_train.log | tail -1)
    [ -n \"\$R\" ] && mkdir -p ${KEEP:-/root/keep} && cp \"\$R\" ${KEEP:-/root/keep}/readme.pt && \\
      FOREGROUND=1 bash studies/device/capability.sh curves readme \"\$R\""
}
case "$cmd" in
curves)
  name=$1 ckpt=$2; shift 2
  controllers=${*:-cpg_rl}
  for curve in $CURVES; do
    job "${name}_$curve" --controllers $controllers --checkpoint "cpg_rl=$ckpt" --rounds "${CURVE_ROUNDS:-200}" \
      --sweep "$curve" --no-nominal
  done
  ;;
points)
  name=$1 ckpt=$2
  base=(--controllers cpg_rl --checkpoint "cpg_rl=$ckpt" --rounds "${POINT_ROUNDS:-1000}" --no-nominal)
  job "${name}_at_rise8" "${base[@]}" --terrains stepped --sweep terrain.step_rise 0.08
  job "${name}_at_tread20" "${base[@]}" --terrains stepped --sweep terrain.step_depth 0.20
  job "${name}_at_blocks8" "${base[@]}" --terrains rugged --sweep terrain.block_height_max 0.08
  job "${name}_at_friction03" "${base[@]}" --terrains complex --sweep randomization.friction 0.3
  job "${name}_at_motors50" "${base[@]}" --terrains complex --sweep motor_strength 0.5
  job "${name}_at_payload1" "${base[@]}" --terrains complex --sweep randomization.payload 1.0
  ;;
wait)
  limit=$1; shift
  while [ "$SECONDS" -lt "$limit" ]; do
    busy=0
    for name in "$@"; do
      for log in "$RUNS/extra/$name"_*.log; do [ -f "$log" ] && ! grep -q "^exit " "$log" && busy=1; done
    done
    [ "$busy" = 0 ] && break
    sleep 5
  done
  for name in "$@"; do
    for log in "$RUNS/extra/$name"_*.log; do [ -f "$log" ] && echo "== $(basename "$log" .log): $(tail -1 "$log")"; done
  done
  ;;
curves4)
  code=$RUNS/code; rm -rf "$code"; mkdir -p "$code"
  tar --exclude='./.dw*' --exclude=./runs --exclude=./.git -cf - . | tar -xf - -C "$code"
  here=studies/device/capability.sh P=studies/capability/policies
  queues=("bash $here curves shipped results/policies/cpg_rl_complex.pt cpg cpg_rl" "$(readme_queue)"
          "bash $here curves seed1 $P/complex_margin_seed1.pt; bash $here curves seed3 $P/complex_margin_seed3.pt"
          "bash $here curves seed2 $P/complex_margin_seed2.pt")
  for gpu in 0 1 2 3; do
    (cd "$code" && CUDA_VISIBLE_DEVICES=$gpu FOREGROUND=1 nohup setsid bash -c "${queues[$gpu]}" \
      > "$RUNS/extra/queue$gpu.log" 2>&1 < /dev/null &)
    echo "GPU $gpu: ${queues[$gpu]}" | head -1
  done
  ;;
margin)
  here=studies/device/capability.sh
  TASK=${TASK:-complex-margin} \
  SEED_AFTER="FOREGROUND=1 bash $here curves \$NAME \$CKPT & FOREGROUND=1 bash $here points \$NAME \$CKPT; wait" \
  GPU3_AFTER="FOREGROUND=1 bash $here curves shipped results/policies/cpg_rl_complex.pt cpg cpg_rl &
    $(readme_queue)
    wait" \
  bash studies/device/time_to_skill.sh gate "$@"
  exit $?
  ;;
*) echo "usage: see the header of $0"; exit 2 ;;
esac
[ "${FOREGROUND:-0}" = 1 ] && wait
exit 0
