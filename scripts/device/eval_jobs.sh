#!/bin/bash
# Run several `hexnewton.evaluate` jobs at once (several may share a GPU), each cut off after EVAL_TIMEOUT_S,
# then pack every report into one archive: $OUT/evals.tgz (NAME/report.md, results.json, figures, NAME.log).
#
#   EVAL_TIMEOUT_S=240 bash scripts/device/eval_jobs.sh \
#     "rugged1000@2:--controllers cpg_rl --checkpoint cpg_rl=/root/keep/rugged.pt --terrains rugged --rounds 1000" ...
#
# Each argument is NAME[@GPU]:EVALUATE_ARGS. Checkpoints usually come from train_runs.sh's $KEEP folder.
set -u
OUT=${OUT:-out}
EVALS=${EVALS:-/root/evals}
mkdir -p "$OUT" "$EVALS"
for spec in "$@"; do
  name=${spec%%:*}; args=${spec#*:}
  case "$name" in *@*) gpu=${name#*@}; name=${name%@*};; *) gpu=${CUDA_VISIBLE_DEVICES:-0};; esac
  ( t=$SECONDS
    CUDA_VISIBLE_DEVICES=$gpu timeout -k 10 "${EVAL_TIMEOUT_S:-240}" python -m hexnewton.evaluate $args \
      --out "$EVALS/$name" --no-progress > "$EVALS/$name.log" 2>&1
    echo "exit $? after $((SECONDS - t)) s" >> "$EVALS/$name.log" ) &
done
wait
tar czf "$OUT/evals.tgz" -C "$EVALS" .
for spec in "$@"; do
  name=${spec%%:*}; name=${name%@*}
  echo "== $name: $(tail -1 "$EVALS/$name.log")"
  grep -E '^\| (flat|rugged|stepped|complex) \|' "$EVALS/$name/report.md" 2>/dev/null | head -8
done
