#!/bin/bash
# Recipe candidates in one device call (studies/device/README.md, "A lease's work as one queue"): one pipeline per
# GPU, all at once, each `python train.py ARGS`, then `gpu.sh pack` (its run to $OUT/run_NAME.tgz, its result to
# $KEEP/NAME.pt), then its result on validation rounds ($VAL_ROUNDS per terrain, `--seed 3000`, deterministic action, one evaluate
# job per terrain of $VAL_TERRAINS on the same GPU; none with VAL_ROUNDS=0), or with `points` the named capability points (capability.sh
# points, $POINT_ROUNDS each, `--seed 3000`). Everything ends by $LIMIT seconds after the start (evaluations are cut
# off there), and the evaluations ($EVALS, default /root/evals) are packed into $OUT/evals.tgz, so the call brings
# back whatever finished: a machine given back after the call keeps nothing. With S2S_ROUNDS set, a validation
# candidate's bundle (`apps.export`) also runs that many rugged rounds in C MuJoCo on the host's cores, beside its
# evaluations (`apps.sim2sim --fixed_terrains --newton none --workers $S2S_WORKERS`, default 12) -> $EVALS/s2s_NAME.
#
#   LIMIT=560 bash studies/device/candidates.sh "stuck1@0:--task complex --seed 1 --env.cpg.stuck_lift 0.3" \
#       "margin600@3:points:--task complex-margin --seed 1 --max_iterations 600"
set -u
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
OUT=${OUT:-out} RUNS=${RUNS:-/root/runs} KEEP=${KEEP:-/root/keep} EVALS=${EVALS:-/root/evals}
export OUT RUNS KEEP
mkdir -p "$OUT" "$RUNS" "$KEEP" "$EVALS"
here=$(cd "$(dirname "$0")" && pwd)
deadline=$((SECONDS + ${LIMIT:-560}))
left() { local s=$((deadline - SECONDS)); echo $((s > 1 ? s : 1)); }   # seconds to the deadline (timeout 0: none)
[ $# -gt 0 ] || { echo "usage: candidates.sh NAME@GPU[:points]:TRAIN_ARGS ..." >&2; exit 2; }
pipeline() {
  local name=$1 gpu=$2 what=$3; shift 3
  CUDA_VISIBLE_DEVICES=$gpu timeout -k 10 $(left) python train.py "$@" --log_dir "$RUNS" \
    --experiment "$name" > "$RUNS/$name.log" 2>&1
  echo "$name: train exit $? at $SECONDS s"
  bash "$here/gpu.sh" pack "$name"
  [ -f "$KEEP/$name.pt" ] || return 0
  [ "${VAL_ROUNDS:-1000}" = 0 ] && { echo "$name: no evaluations (VAL_ROUNDS=0)"; return 0; }
  if [ "$what" = points ]; then
    CUDA_VISIBLE_DEVICES=$gpu RUNS=$EVALS FOREGROUND=1 MAX_JOBS=6 POINT_ROUNDS=${POINT_ROUNDS:-500} \
      EVAL_ARGS="--seed 3000" timeout -k 10 $(left) bash "$here/capability.sh" points "$name" \
      "$KEEP/$name.pt"
  else
    if [ -n "${S2S_ROUNDS:-}" ]; then
      ( timeout -k 10 $(left) python -m hexnewton.apps.export --checkpoint "$KEEP/$name.pt" \
          --out "$EVALS/bundle_$name" \
          && timeout -k 10 $(left) python -m hexnewton.apps.sim2sim "$EVALS/bundle_$name" --terrains rugged \
          --rounds "$S2S_ROUNDS" --fixed_terrains --newton none --workers "${S2S_WORKERS:-12}" --out "$EVALS/s2s_$name"
        echo "sim2sim exit $? at $SECONDS s" ) > "$EVALS/s2s_$name.log" 2>&1 &
    fi
    for t in ${VAL_TERRAINS:-complex rugged stepped}; do
      ( CUDA_VISIBLE_DEVICES=$gpu timeout -k 10 $(left) python -m hexnewton.apps.evaluate \
          --controllers cpg_rl --checkpoint "cpg_rl=$KEEP/$name.pt" --terrains "$t" --rounds "${VAL_ROUNDS:-1000}" \
          --seed 3000 --out "$EVALS/${name}_$t" --no-progress > "$EVALS/${name}_$t.log" 2>&1
        echo "exit $?" >> "$EVALS/${name}_$t.log" ) &
    done
    wait
  fi
  echo "$name: evaluations ended at $SECONDS s"
}
for spec in "$@"; do
  head=${spec%%:*} rest=${spec#*:} what=val
  case "$rest" in points:*) what=points; rest=${rest#points:};; esac
  # shellcheck disable=SC2086
  pipeline "${head%@*}" "${head#*@}" "$what" $rest &
done
wait
tar czf "$OUT/evals.tgz" -C "$EVALS" .
for f in "$EVALS"/*/report.md "$EVALS"/extra/*/report.md; do
  [ -f "$f" ] && { echo "== $f"; grep -E '^\| ' "$f" | head -6; }
done
