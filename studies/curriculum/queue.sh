#!/bin/bash
# The curriculum study's lease on one GPU (`bash studies/device/gpu.sh queue studies/curriculum/queue.sh`; the chunk
# calls and the install first: studies/device/README.md). In order:
# 1. a short warm-up run (the kernels Warp compiles for this code, once, not in every run);
# 2. every arm of $ARMS (studies/curriculum/arms.py) on every seed of $SEEDS and the recipe on $RECIPE_SEEDS (1: what
#    its curriculum saw, counted as the arms' are), all at once on the GPU
#    (`python train.py --task complex --seed N FLAGS`, candidates.sh: each run packed, its result on $VAL_ROUNDS
#    validation rounds per course, seed 3000, deterministic action); their times are shared, not timed;
# 3. once their training has ended (REF_DELAY=SECONDS: that long after their start), on the same validation rounds:
#    the recipe's kept results $KEPT (studies/learner/runs/NAME/policy.pt, fetched from git history before the chunk
#    calls: `python studies/house/kept.py fetch studies/learner`), the shipped policy and the fixed CPG (SHIPPED=0:
#    neither).
# Then `bash studies/device/gpu.sh poll 560` and `bash studies/curriculum/queue.sh collect` ($OUT/curriculum.tgz.NN;
# here: `mkdir -p LEASE && cat curriculum.tgz.* | tar xzf - -C LEASE && python studies/curriculum/build.py --add LEASE`).
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
EVALS=${EVALS:-/root/evals} RUNS=${RUNS:-/root/runs} KEEP=${KEEP:-/root/keep} RUNS_OUT=${RUNS_OUT:-/root/cur_out}
export EVALS RUNS KEEP
mkdir -p "$EVALS" "$RUNS" "$KEEP" "$RUNS_OUT"
if [ "${1:-}" = collect ]; then   # consoles, configs, timings, results, evaluations; the Warp cache apart
  out=${OUT:-out}; mkdir -p "$out"
  stage=/root/cur_stage; rm -rf "$stage"; mkdir -p "$stage" && ln -s "$RUNS" "$stage/runs" && ln -s "$EVALS" "$stage/evals"
  files=$(cd "$stage" && ls runs/*.log runs/*/*/config.json runs/*/*/timing.json runs/*/*/model_result.pt \
    evals/*/results.json evals/*/report.md evals/*.log 2>/dev/null)
  tar czhf - -C "$stage" $files | split -b 9M -d - "$out/curriculum.tgz."
  [ "${CACHE:-0}" = 1 ] && tar czf - -C /root/.cache warp | split -b 9M -d - "$out/gpucache.tgz."
  ls -la "$out"; exit 0
fi
ARMS=${ARMS:-anchor spread both} SEEDS=${SEEDS:-1 2} VAL_ROUNDS=${VAL_ROUNDS:-1000}
KEPT=${KEPT:-}
for name in $KEPT; do
  [ -f "studies/learner/runs/$name/policy.pt" ] || { echo "queue.sh: no studies/learner/runs/$name/policy.pt \
(python studies/house/kept.py fetch studies/learner, before the chunk calls)" >&2; exit 2; }
done
echo "$(date +%T) the curriculum queue: arms '$ARMS' on seeds '$SEEDS', $VAL_ROUNDS validation rounds, kept '$KEPT'"
python train.py --task complex --num_envs 256 --max_iterations 2 --agent.validation_rounds 0 --log_dir /root/warm \
  > /root/warm.log 2>&1
echo "$(date +%T) warm-up exit $?"
specs=""
for seed in $SEEDS; do
  for arm in $ARMS; do
    f=$(python studies/curriculum/arms.py --flags "$arm") || continue
    specs="$specs|${arm}_s$seed@0:--task complex --seed $seed $f"
  done
done
for seed in ${RECIPE_SEEDS-1}; do specs="$specs|recipe_s$seed@0:--task complex --seed $seed"; done   # its lane counts
IFS='|' read -r -a list <<< "${specs#|}"
OUT=$RUNS_OUT LIMIT=${LIMIT:-1500} VAL_ROUNDS=$VAL_ROUNDS bash studies/device/candidates.sh "${list[@]}" \
  > "$RUNS/candidates.log" 2>&1 &
cand=$!
# the references' evaluations once every run's training (and its own validation) has ended: twelve evaluations beside
# the runs hold them at about twice their time per iteration. REF_DELAY=SECONDS starts them that long after the runs.
if [ -n "${REF_DELAY:-}" ]; then
  sleep "$REF_DELAY"
else
  while kill -0 "$cand" 2>/dev/null && [ "$(grep -c ': train exit' "$RUNS/candidates.log")" -lt "${#list[@]}" ]; do
    sleep 10
  done
fi
[ "${SHIPPED:-1}" = 1 ] || echo "$(date +%T) no shipped policy or fixed CPG (SHIPPED=0)"
evaluate() {   # NAME TERRAIN CHECKPOINT [MORE evaluate FLAGS]
  local name=$1 t=$2 ckpt=$3; shift 3
  python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" --terrains "$t" \
    --rounds "$VAL_ROUNDS" --seed 3000 --out "$EVALS/${name}_$t" --no-progress "$@" > "$EVALS/${name}_$t.log" 2>&1
  echo "exit $?" >> "$EVALS/${name}_$t.log"
}
for t in complex rugged stepped; do
  [ "${SHIPPED:-1}" = 1 ] && evaluate shipped "$t" results/policies/cpg_rl_complex.pt --controllers cpg cpg_rl &
  for name in $KEPT; do
    evaluate "recipe_$name" "$t" "studies/learner/runs/$name/policy.pt" &
  done
done
wait
echo "$(date +%T) the curriculum queue ended"
