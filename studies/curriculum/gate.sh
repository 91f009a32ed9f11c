#!/bin/bash
# The 5-seed gate of the complex recipe (studies/curriculum/README.md, "The gate") as one lease's queue on one GPU
# (`bash studies/device/gpu.sh queue studies/curriculum/gate.sh`; the chunk calls and the install first):
# 1. a short warm-up run (the kernels Warp compiles for this code, once);
# 2. `python train.py --task complex --seed N FLAGS` for N in $GATE_SEEDS (1 2 3 4 5), one after another, alone on the
#    GPU (each run's time from process start counts), runs gate_sN, each result packed to $KEEP/gate_sN.pt;
#    FLAGS: $GATE_FLAGS, else the arm $ARM's (studies/curriculum/arms.py; default recipe: none);
# 3. the test rounds (the evaluate default seed, deterministic action): every result, and the shipped policy with the
#    fixed CPG, on $RUGGED (4000) rugged, $COMPLEX (4000) complex and $STEPPED (1000) stepped rounds, all at once.
# A gate split over two leases: TEST=0 in the first (the results come back with `collect`, gate/*.pt), TRAIN=0
# TEST_FROM=FOLDER in the second (FOLDER/gate_sN.pt, carried into the call; runs without a result are left out).
# Then `bash studies/device/gpu.sh poll 560` and `bash studies/curriculum/gate.sh collect` ($OUT/gate.tgz.NN; here:
# `mkdir -p LEASE && cat gate.tgz.* | tar xzf - -C LEASE && python studies/curriculum/build.py --add LEASE`).
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
EVALS=${EVALS:-/root/evals} RUNS=${RUNS:-/root/runs} KEEP=${KEEP:-/root/keep} RUNS_OUT=${RUNS_OUT:-/root/gate_out}
export EVALS RUNS KEEP
mkdir -p "$EVALS" "$RUNS" "$KEEP" "$RUNS_OUT"
if [ "${1:-}" = collect ]; then   # consoles, configs, timings, the results (gate/gate_sN.pt), evaluations
  out=${OUT:-out}; mkdir -p "$out"
  stage=/root/gate_stage; rm -rf "$stage"; mkdir -p "$stage" && ln -s "$RUNS" "$stage/runs" \
    && ln -s "$EVALS" "$stage/evals" && ln -s "$KEEP" "$stage/gate"
  files=$(cd "$stage" && ls runs/*.log runs/*/*/config.json runs/*/*/timing.json gate/gate_s*.pt \
    evals/*/results.json evals/*/report.md evals/*.log 2>/dev/null)
  tar czhf - -C "$stage" $files | split -b 9M -d - "$out/gate.tgz."
  ls -la "$out"; exit 0
fi
GATE_SEEDS=${GATE_SEEDS:-1 2 3 4 5}
if [ -z "${GATE_FLAGS+x}" ]; then GATE_FLAGS=$(python studies/curriculum/arms.py --flags "${ARM:-recipe}") || exit 2; fi
echo "$(date +%T) the gate gate_sN, N in '$GATE_SEEDS': python train.py --task complex --seed N $GATE_FLAGS"
if [ "${TRAIN:-1}" = 1 ]; then
  python train.py --task complex --num_envs 256 --max_iterations 2 --agent.validation_rounds 0 --log_dir /root/warm \
    > /root/warm.log 2>&1
  echo "$(date +%T) warm-up exit $?"
  for seed in $GATE_SEEDS; do
    name=gate_s$seed
    # shellcheck disable=SC2086
    python train.py --task complex --seed "$seed" $GATE_FLAGS --log_dir "$RUNS" --experiment "$name" \
      > "$RUNS/$name.log" 2>&1
    echo "$(date +%T) $name: train exit $?, $(grep 'from process start to the exported result' "$RUNS/$name.log")"
    OUT=$RUNS_OUT bash studies/device/gpu.sh pack "$name"
  done
fi
[ "${TEST:-1}" = 1 ] || { echo "$(date +%T) no test rounds (TEST=0): collect brings the results back"; exit 0; }
from=${TEST_FROM:-$KEEP}
evaluate() {   # NAME TERRAIN ROUNDS CHECKPOINT [MORE evaluate FLAGS]
  local name=$1 t=$2 n=$3 ckpt=$4; shift 4
  python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" --terrains "$t" --rounds "$n" \
    --out "$EVALS/${name}_$t" --no-progress "$@" > "$EVALS/${name}_$t.log" 2>&1
  echo "exit $?" >> "$EVALS/${name}_$t.log"
}
for t in rugged complex stepped; do
  case $t in rugged) n=${RUGGED:-4000};; complex) n=${COMPLEX:-4000};; stepped) n=${STEPPED:-1000};; esac
  evaluate gate_shipped "$t" "$n" results/policies/cpg_rl_complex.pt --controllers cpg cpg_rl &
  for seed in $GATE_SEEDS; do
    if [ -f "$from/gate_s$seed.pt" ]; then evaluate "gate_s$seed" "$t" "$n" "$from/gate_s$seed.pt" &
    else echo "gate.sh: no result $from/gate_s$seed.pt: gate_s$seed left out of the $t test rounds"; fi
  done
done
wait
echo "$(date +%T) the gate's queue ended"
