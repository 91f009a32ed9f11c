#!/bin/bash
# A queue (`bash studies/device/gpu.sh queue studies/device/learner.sh`) for one H200: the learner study
# (studies/learner, its README). In order:
# 1. the arms still missing ($ARMS, default actor; ARMS= none) on $SEEDS (1 2), one lane per seed, each training its
#    arms one after another (candidates.sh: train.py with its own validation, the run packed to
#    $RUNS_OUT/run_NAME.tgz, its result on $VAL_ROUNDS validation rounds per course, seed 3000, deterministic
#    action); beside them the study's kept results that lack those rounds ($KEPT, default none:
#    studies/learner/runs/NAME/policy.pt, `python studies/house/kept.py fetch studies/learner` first); with SHIPPED=1
#    also the shipped policy and the fixed CPG on the same rounds; with FAIR_JOBS set, the paper comparison's runs it
#    names (fair_comparison.sh);
# 2. the choice: `studies/learner/build.py --choose` over the study and this lease's runs names the changes that paid
#    (their train.py flags) and `--gate-name` the gate's run names (gate_ARM-ARM; gate for the recipe itself), unless
#    $GATE_FLAGS is given (then $GATE_NAME, default gate; the study's runs/ folder set aside for the chunk calls leaves
#    the choice nothing to read on the device: give both);
# 3. with GATE=1, the gate: `python train.py --task complex --seed N FLAGS` for N in $GATE_SEEDS (1 2 3), one after
#    another and alone on the GPU (the time counts), runs GATE_NAME_sN, then every result, the shipped policy and the
#    fixed CPG on 1000 test rounds per terrain (the evaluate default seed), all at once (not with GATE_TEST=0: a gate
#    split over leases, its test rounds then through TEST_KEPT).
# With TEST_KEPT="gate_s1 gate_s2 gate_s3" (say ARMS= KEPT= beside it) the study's kept results of those names
# (studies/learner/runs/NAME/policy.pt), the shipped policy and the fixed CPG go on 1000 test rounds per terrain first:
# a gate whose test evaluations did not finish in its lease ($TEST_TERRAINS: the terrains still missing, default all
# three).
# With ARMS_AFTER_GATE=1 (and GATE=1) the arms' lanes start after the gate's seeds, beside its test rounds: the
# gate's seeds run alone first, and the arms' times are shared (their comparison on validation is not a time).
# With ALONE=1 the arms' runs go one after another, each alone on the GPU, and their results' and the kept results'
# validation rounds all at once after the last (the times count; the lanes' runs share the GPU).
# With AVERAGE=1 every run of the lease also validates the weight average of its candidates
# (`--agent.validation_average true`: one more candidate; the study compares arms on the saved checkpoints).
# Then, from the next calls: `bash studies/device/gpu.sh poll 560` and `bash studies/device/learner.sh collect`
# (everything in 9 MB parts, $OUT/learner.tgz.NN; here: `cat learner.tgz.* | tar xzf - -C LEASE` and
# `python studies/learner/build.py --add LEASE`).
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
EVALS=${EVALS:-/root/evals} QUEUE=${QUEUE:-/root/queue} RUNS=${RUNS:-/root/runs} KEEP=${KEEP:-/root/keep}
RUNS_OUT=${RUNS_OUT:-/root/learner_out}   # where candidates.sh packs (not the call's $OUT: it is emptied per call)
export EVALS RUNS KEEP
mkdir -p "$EVALS" "$RUNS" "$KEEP" "$RUNS_OUT"
if [ "${1:-}" = collect ]; then   # logs, configs, timings, results (not the other checkpoints), evaluations
  out=${OUT:-out}; mkdir -p "$out"
  stage=/root/learner_stage; rm -rf "$stage"; mkdir -p "$stage" && ln -s "$RUNS" "$stage/runs" && ln -s "$EVALS" "$stage/evals"
  files=$(cd "$stage" && ls runs/*.log runs/*/*/config.json runs/*/*/timing.json runs/*/*/model_result.pt \
    evals/*/results.json evals/*/report.md evals/*.log 2>/dev/null)
  tar czhf - -C "$stage" $files | split -b 9M -d - "$out/learner.tgz."
  ls -la "$out"; exit 0
fi
ARMS=${ARMS-actor} SEEDS=${SEEDS:-1 2} VAL_ROUNDS=${VAL_ROUNDS:-500} KEPT=${KEPT:-}
EXTRA=""; [ "${AVERAGE:-0}" = 1 ] && EXTRA="--agent.validation_average true"
AFTER=${ARMS_AFTER_GATE:-0}
if [ "$AFTER" = 1 ] && [ "${GATE:-0}" != 1 ]; then
  echo "learner.sh: ARMS_AFTER_GATE=1 needs GATE=1" >&2; exit 2
fi
flags() { python studies/learner/build.py --flags "$1"; }   # an arm's train.py flags (build.py ARM_FLAGS)
evaluate() {   # NAME TERRAIN ROUNDS CHECKPOINT [MORE evaluate FLAGS]
  local name=$1 t=$2 rounds=$3 ckpt=$4; shift 4
  python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" --terrains "$t" \
    --rounds "$rounds" --out "$EVALS/${name}_$t" --no-progress "$@" > "$EVALS/${name}_$t.log" 2>&1
  echo "exit $?" >> "$EVALS/${name}_$t.log"
}
test_rounds() {   # NAME=CHECKPOINT...: each (one without its checkpoint is said and left out), the shipped policy and
  # the fixed CPG (as STEM_shipped, STEM the first name's gate: gate_tf32 for gate_tf32_s2) on 1000 test rounds per
  # terrain of $TEST_TERRAINS (the evaluate default seed), all at once
  local t spec stem=${1%%=*}
  stem=${stem%_s[0-9]*}
  for t in ${TEST_TERRAINS:-complex rugged stepped}; do
    evaluate "${stem:-gate}_shipped" "$t" 1000 results/policies/cpg_rl_complex.pt --controllers cpg cpg_rl &
    for spec in "$@"; do
      if [ -f "${spec#*=}" ]; then evaluate "${spec%%=*}" "$t" 1000 "${spec#*=}" &
      else echo "learner.sh: ${spec%%=*} has no checkpoint ${spec#*=}: left out of the $t test rounds"; fi
    done
  done
}
for name in $KEPT ${TEST_KEPT:-}; do
  [ -f "studies/learner/runs/$name/policy.pt" ] || { echo "learner.sh: no studies/learner/runs/$name/policy.pt \
(python studies/house/kept.py fetch studies/learner, before the chunk calls)" >&2; exit 2; }
done
echo "$(date +%T) the learner's queue: arms '$ARMS' on seeds '$SEEDS', kept results '$KEPT'"
[ -n "${FAIR_JOBS:-}" ] && { JOBS=$FAIR_JOBS PER_GPU=4 bash studies/device/fair_comparison.sh > "$QUEUE/fair.log" 2>&1 & }
kept_rounds() {   # the kept results' validation rounds, at once
  local name t
  for name in $KEPT; do
    for t in complex rugged stepped; do
      evaluate "$name" "$t" "$VAL_ROUNDS" "studies/learner/runs/$name/policy.pt" --seed 3000 &
    done
  done
}
[ "${ALONE:-0}" = 1 ] || kept_rounds   # with ALONE=1 they wait for the runs, which run alone
if [ "${SHIPPED:-0}" = 1 ]; then
  for t in complex rugged stepped; do
    evaluate shipped "$t" "$VAL_ROUNDS" results/policies/cpg_rl_complex.pt --seed 3000 --controllers cpg cpg_rl &
  done
fi
if [ -n "${TEST_KEPT:-}" ]; then
  # shellcheck disable=SC2046
  test_rounds $(for name in $TEST_KEPT; do echo "$name=studies/learner/runs/$name/policy.pt"; done)
fi
if [ "${ALONE:-0}" = 1 ]; then   # one run at a time, alone on the GPU (the times count), then their evaluations at once
  done_runs=""
  for seed in $SEEDS; do
    for arm in $ARMS; do
      f=$(flags "$arm") || continue
      # shellcheck disable=SC2086
      OUT=$RUNS_OUT LIMIT=${ARM_LIMIT:-1200} VAL_ROUNDS=0 bash studies/device/candidates.sh \
        "${arm}_s$seed@0:--task complex --seed $seed $f $EXTRA"
      echo "$(date +%T) ${arm}_s$seed ended"
      done_runs="$done_runs ${arm}_s$seed"
    done
  done
  kept_rounds
  for name in $done_runs; do
    [ -f "$KEEP/$name.pt" ] || continue
    for t in complex rugged stepped; do evaluate "$name" "$t" "$VAL_ROUNDS" "$KEEP/$name.pt" --seed 3000 & done
  done
  ARMS=""
fi
lanes() {   # the arms' lanes in the background, one per seed, each training its arms one after another
  local seed
  for seed in $SEEDS; do
    [ -n "$ARMS" ] || break
    (
      for arm in $ARMS; do
        f=$(flags "$arm") || continue
        # shellcheck disable=SC2086
        OUT=$RUNS_OUT LIMIT=${ARM_LIMIT:-1200} VAL_ROUNDS=$VAL_ROUNDS bash studies/device/candidates.sh \
          "${arm}_s$seed@0:--task complex --seed $seed $f $EXTRA"
        echo "$(date +%T) ${arm}_s$seed ended"
      done
    ) &
    sleep "${LANE_GAP:-20}"   # the lanes start apart (their imports and builds)
  done
}
[ "$AFTER" = 1 ] || lanes
wait
echo "$(date +%T) the arms and their evaluations ended"
[ "${GATE:-0}" = 1 ] || exit 0
if [ -z "${GATE_FLAGS+x}" ]; then
  GATE_FLAGS=$(python studies/learner/build.py --choose --runs "$RUNS") || exit 1
  GATE_NAME=${GATE_NAME:-$(python studies/learner/build.py --gate-name --runs "$RUNS")} || exit 1
fi
GATE_NAME=${GATE_NAME:-gate} GATE_SEEDS=${GATE_SEEDS:-1 2 3}
echo "$(date +%T) the gate ${GATE_NAME}_sN, N in $GATE_SEEDS: python train.py --task complex --seed N $GATE_FLAGS"
specs=""
for seed in $GATE_SEEDS; do
  name=${GATE_NAME}_s$seed
  # shellcheck disable=SC2086
  python train.py --task complex --seed "$seed" $GATE_FLAGS $EXTRA --log_dir "$RUNS" --experiment "$name" \
    > "$RUNS/$name.log" 2>&1
  echo "$(date +%T) $name: train exit $?"
  OUT=$RUNS_OUT bash studies/device/gpu.sh pack "$name"
  specs="$specs $name=$KEEP/$name.pt"
done
# shellcheck disable=SC2086  # NAME=CHECKPOINT words
[ "${GATE_TEST:-1}" = 1 ] && test_rounds $specs
[ "$AFTER" = 1 ] && lanes   # beside the test rounds: the gate's seeds are done, the GPU is shared from here on
wait
echo "$(date +%T) the learner's queue ended"
