#!/bin/bash
# The any-hexapod study's lease on one GPU (studies/any_hexapod/README.md; `bash studies/device/gpu.sh queue
# studies/any_hexapod/queue.sh`, the chunk calls and the install first: studies/device/README.md). In order:
# 1. a short warm-up run on $ROBOT (the kernels Warp compiles for this code, once, not in every run);
# 2. per seed of $SEEDS (1), one after another, each alone on the GPU (its time from process start counts):
#    `python train.py --task complex --robot $ROBOT --seed N` (scratch_sN) and the same with `--init $INIT`
#    (init_sN; INIT default results/policies/cpg_rl_complex.pt), the task's iterations (300) for both; each result
#    (model_result.pt, chosen on the validation rounds, seed 3000) kept as $ROOT/policies/NAME.pt with its timing;
# 3. at once: every result and the fixed CPG (the complex task's physics) on $ROUNDS (1000) test rounds per course of
#    $TERRAINS (rugged stepped complex; evaluate's default test seed, deterministic action), one evaluate job per
#    policy and course on the GPU; beside them on the host's cores, the result better on its validation rounds
#    (`build.py --better`; BETTER=NAME chooses) exported as a bundle and walked in C MuJoCo, $S2S_ROUNDS (100) rounds
#    per course with $S2S_WORKERS (12) processes (S2S_ROUNDS=0: none); build.py sets it beside Newton's numbers.
# Everything ends by $LIMIT (1500) s after the start. Split over two leases: TEST=0 in the first (`collect` brings the
# results back), TRAIN=0 TEST_FROM=FOLDER in the second (FOLDER/NAME.pt and NAME.timing.json, carried into the call).
# Then `bash studies/device/gpu.sh poll 560` and `bash studies/any_hexapod/queue.sh collect` ($OUT/any_hexapod.tgz.NN;
# here: `mkdir -p LEASE && cat any_hexapod.tgz.* | tar xzf - -C LEASE && python studies/any_hexapod/build.py --add
# LEASE`).
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
ROOT=${ROOT:-/root/any_hexapod}
RUNS=$ROOT/runs EVALS=$ROOT/evals KEEP=$ROOT/policies
mkdir -p "$RUNS" "$EVALS" "$KEEP" "$ROOT/packs"
if [ "${1:-}" = collect ]; then   # consoles, configs, timings, the results, evaluations, sim2sim; the Warp cache apart
  out=${OUT:-out}; mkdir -p "$out"
  files=$(cd "$ROOT" && ls lease.json warm.log runs/*.log runs/*/*/config.json runs/*/*/timing.json policies/*.pt \
    policies/*.timing.json evals/*/results.json evals/*/report.md evals/*.log evals/s2s_*/details.json \
    evals/bundle_*/controller.json 2>/dev/null)
  tar czf - -C "$ROOT" $files | split -b 9M -d - "$out/any_hexapod.tgz."
  [ "${CACHE:-0}" = 1 ] && tar czf - -C /root/.cache warp | split -b 9M -d - "$out/gpucache.tgz."
  ls -la "$out"; exit 0
fi
ROBOT=${ROBOT:-mx_phoenix} SEEDS=${SEEDS:-1} ROUNDS=${ROUNDS:-1000} TERRAINS=${TERRAINS:-rugged stepped complex}
S2S_ROUNDS=${S2S_ROUNDS:-100} S2S_WORKERS=${S2S_WORKERS:-12} INIT=${INIT:-results/policies/cpg_rl_complex.pt}
TRAIN=${TRAIN:-1} TEST=${TEST:-1}
steps=${MAX_STEPS:+--max_steps $MAX_STEPS}   # MAX_STEPS: every round cut there (a smoke run)
deadline=$((SECONDS + ${LIMIT:-1500}))
left() { local s=$((deadline - SECONDS)); echo $((s > 1 ? s : 1)); }   # seconds to the deadline
gpu=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1)
cat > "$ROOT/lease.json" << EOF
{"date": "$(date +%F)", "started": "$(date +%T)", "gpu": "${gpu:-none}", "robot": "$ROBOT", "seeds": "$SEEDS",
 "rounds": $ROUNDS, "terrains": "$TERRAINS", "s2s_rounds": $S2S_ROUNDS, "s2s_workers": $S2S_WORKERS,
 "init": "$INIT", "train": $TRAIN, "test": $TEST, "limit_s": ${LIMIT:-1500}, "test_from": "${TEST_FROM:-}"}
EOF
echo "$(date +%T) the any-hexapod queue on $ROBOT: seeds '$SEEDS', $ROUNDS test rounds on '$TERRAINS', sim2sim" \
  "$S2S_ROUNDS rounds ($S2S_WORKERS workers); TRAIN=$TRAIN TEST=$TEST"
if [ "${WARM:-$TRAIN}" = 1 ]; then
  timeout -k 10 "$(left)" python train.py --task complex --robot "$ROBOT" --num_envs 256 --max_iterations 2 \
    --agent.validation_rounds 0 --log_dir "$ROOT/warm" > "$ROOT/warm.log" 2>&1
  echo "$(date +%T) warm-up exit $?"
fi
train() {   # NAME SEED [MORE train.py FLAGS]: alone on the GPU, its result and timing kept in $KEEP
  local name=$1 seed=$2; shift 2
  timeout -k 10 "$(left)" python train.py --task complex --robot "$ROBOT" --seed "$seed" "$@" --log_dir "$RUNS" \
    --experiment "$name" > "$RUNS/$name.log" 2>&1
  echo "$(date +%T) $name: train exit $?, $(grep 'from process start to the exported result' "$RUNS/$name.log")"
  OUT=$ROOT/packs RUNS=$RUNS KEEP=$KEEP bash studies/device/gpu.sh pack "$name"
  local timing; timing=$(ls "$RUNS/$name"/*/timing.json 2>/dev/null | tail -1)
  [ -n "$timing" ] && cp "$timing" "$KEEP/$name.timing.json"
}
if [ "$TRAIN" = 1 ]; then
  for seed in $SEEDS; do
    train "scratch_s$seed" "$seed"
    train "init_s$seed" "$seed" --init "$INIT"
  done
fi
[ "$TEST" = 1 ] || { echo "$(date +%T) no test rounds (TEST=0): collect brings the results back"; exit 0; }
from=${TEST_FROM:-$KEEP}
[ "$from" = "$KEEP" ] || cp "$from"/*.pt "$from"/*.timing.json "$KEEP/" 2>/dev/null
fixed_sim=$(python -c "from hexnewton.tasks import task; s = task('complex').env.sim
print(f'--env.sim.frame_dt {s.frame_dt} --env.sim.substeps {s.substeps}')")
# shellcheck disable=SC2086
evaluate() {   # JOB TERRAIN evaluate FLAGS...
  local job=$1 t=$2; shift 2
  timeout -k 10 "$(left)" python -m hexnewton.apps.evaluate --robot "$ROBOT" "$@" --terrains "$t" --rounds "$ROUNDS" \
    --out "$EVALS/${job}_$t" --no-progress $steps > "$EVALS/${job}_$t.log" 2>&1
  echo "exit $?" >> "$EVALS/${job}_$t.log"
}
for t in $TERRAINS; do
  # shellcheck disable=SC2086
  evaluate fixed_cpg "$t" --controllers cpg $fixed_sim &
  for seed in $SEEDS; do
    for name in "scratch_s$seed" "init_s$seed"; do
      if [ -f "$KEEP/$name.pt" ]; then evaluate "$name" "$t" --controllers cpg_rl --checkpoint "cpg_rl=$KEEP/$name.pt" &
      else echo "queue.sh: no result $KEEP/$name.pt: $name left out of the $t test rounds"; fi
    done
  done
done
if [ "$S2S_ROUNDS" != 0 ]; then
  pairs=""
  for seed in $SEEDS; do
    for name in "scratch_s$seed" "init_s$seed"; do
      [ -f "$KEEP/$name.pt" ] && pairs+=" $name=$KEEP/$name.timing.json"
    done
  done
  # shellcheck disable=SC2086
  better=${BETTER:-$(python studies/any_hexapod/build.py --better $pairs)}
  if [ -n "$better" ] && [ -f "$KEEP/$better.pt" ]; then
    echo "$(date +%T) sim2sim: $better (the better on its validation rounds) on $S2S_ROUNDS rounds per course"
    ( timeout -k 10 "$(left)" python -m hexnewton.apps.export --checkpoint "$KEEP/$better.pt" --robot "$ROBOT" \
        --out "$EVALS/bundle_$better" \
      && timeout -k 10 "$(left)" python -m hexnewton.apps.sim2sim "$EVALS/bundle_$better" --robot "$ROBOT" \
        --terrains $TERRAINS --rounds "$S2S_ROUNDS" $steps --newton none --workers "$S2S_WORKERS" \
        --out "$EVALS/s2s_$better"
      echo "sim2sim exit $? at $SECONDS s" ) > "$EVALS/s2s_$better.log" 2>&1 &
  else
    echo "queue.sh: no result for sim2sim (BETTER '${BETTER:-}', results '$pairs')"
  fi
fi
wait
for f in "$EVALS"/*/report.md; do [ -f "$f" ] && { echo "== $f"; grep -E '^\| ' "$f" | head -6; }; done
echo "$(date +%T) the any-hexapod queue ended"
