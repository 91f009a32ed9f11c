#!/bin/bash
# A queue (`bash scripts/device/gpu.sh queue scripts/device/learner.sh`) for one H200: the learner's changes one at a
# time against the complex recipe (studies/learner), beside the paper comparison's pure-DRL seed 3
# (fair_comparison.sh with JOBS=joint_staged:3):
# - arms ($ARMS): recipe (`--task complex`), critic (`--env.obs.critic true`: the asymmetric critic), actor
#   (`--env.obs.gyro true --env.obs.last_action true`: the gyro and the last actions in the actor's observation);
# - two lanes, one per seed of $SEEDS (1 2), each training its arms one after another (candidates.sh: train.py with
#   its own validation, the run packed to out/run_NAME.tgz, its result on $VAL_ROUNDS validation rounds per course,
#   seed 3000, deterministic action), so that the arms' twins share the GPU alike;
# - the shipped policy and the fixed CPG (on the shipped policy's physics) on the same validation rounds.
# Then, from the next call: `bash scripts/device/gpu.sh poll 560`, `bash scripts/device/gpu.sh collect` (the
# comparison) and `bash scripts/device/learner.sh collect` (the learner's runs and evaluations -> $OUT/learner.tgz.NN).
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
EVALS=${EVALS:-/root/evals} QUEUE=${QUEUE:-/root/queue}
export EVALS
if [ "${1:-}" = collect ]; then   # everything the queue wrote, in 9 MB parts (a call brings back 8 files)
  out=${OUT:-out}; mkdir -p "$out"
  tar czf - -C "$PWD/out" $(cd out && ls run_*.tgz) -C "$EVALS" . -C "$QUEUE" . | split -b 9M -d - "$out/learner.tgz."
  ls -la "$out"; exit 0
fi
ARMS=${ARMS:-critic recipe actor} SEEDS=${SEEDS:-1 2} VAL_ROUNDS=${VAL_ROUNDS:-500}
flags() {
  case $1 in
    recipe) echo "--task complex" ;;
    critic) echo "--task complex --env.obs.critic true" ;;
    actor) echo "--task complex --env.obs.gyro true --env.obs.last_action true" ;;
    *) echo "learner.sh: no arm $1" >&2; return 1 ;;
  esac
}
JOBS=${FAIR_JOBS:-joint_staged:3} PER_GPU=4 bash scripts/device/fair_comparison.sh > "$QUEUE/fair.log" 2>&1 &
mkdir -p "$EVALS"
for t in complex rugged stepped; do
  ( python -m hexnewton.apps.evaluate --controllers cpg cpg_rl --checkpoint cpg_rl=results/policies/cpg_rl_complex.pt \
      --terrains "$t" --rounds "$VAL_ROUNDS" --seed 3000 --out "$EVALS/shipped_$t" --no-progress \
      > "$EVALS/shipped_$t.log" 2>&1; echo "exit $?" >> "$EVALS/shipped_$t.log" ) &
done
for seed in $SEEDS; do
  (
    for arm in $ARMS; do
      f=$(flags "$arm") || continue
      # shellcheck disable=SC2086
      LIMIT=${ARM_LIMIT:-1200} VAL_ROUNDS=$VAL_ROUNDS bash scripts/device/candidates.sh "${arm}_s$seed@0:$f --seed $seed"
      echo "$(date +%T) ${arm}_s$seed ended"
    done
  ) &
  sleep 20
done
wait
echo "$(date +%T) the learner's queue ended"
