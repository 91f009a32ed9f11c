#!/bin/bash
# Walking to any goal (studies/navigate/README.md) as one queue on one H200, from a copy of the tree after the chunk
# calls and `gpu.sh install` (studies/device/README.md, "A lease's work as one queue"):
#
#   bash studies/device/gpu.sh queue studies/navigate/queue.sh
#   bash studies/device/gpu.sh poll 560 '/root/navigate/*.tgz'    # the next call at once, then until "queue ended"
#
# For each task, navigate-flat then navigate-rugged: the one training command (its wall time from process start in
# train_<t>.time, timing.json in the run), the navigation evaluation on 1000 unseen rounds per bearing and 1000 of the
# square (deterministic action, the test seeds) and the bundle; after the flat task, its bundle in C MuJoCo through the
# same square, 100 rounds on the host's cores, beside Newton's (so a lease that ends during navigate-rugged holds the
# flat task whole). The square's video is made from the kept policy on a CPU (build.py video T). Each step's outputs
# are packed into $NAV/<step>.tgz as soon as they exist (a lost machine keeps what was polled): not into the call's
# $OUT, which the device empties at the start of every call.
#
# TASKS (default "flat rugged") picks the tasks; a task named in TRAINED is not trained again: its policy kept in the
# study ($KEPT_RUNS/<terrain>/policy.pt, default studies/navigate/runs: flat's a link to the shipped policy, rugged's
# from git history, `python studies/house/kept.py fetch studies/navigate` before the chunk calls) is evaluated and
# exported.
set -u
NAV=${NAV:-/root/navigate} ROUNDS=${ROUNDS:-1000} S2S_ROUNDS=${S2S_ROUNDS:-100}
NAV=$(mkdir -p "$NAV" && cd "$NAV" && pwd)
pack() { tar czf "$NAV/$1.tgz" -C "$NAV" "${@:2}" 2>/dev/null; echo "$(date +%T) packed $1"; }
for t in ${TASKS:-flat rugged}; do
  if [[ " ${TRAINED:-} " == *" $t "* ]]; then
    ckpt=${KEPT_RUNS:-studies/navigate/runs}/$t/policy.pt
    [ -f "$ckpt" ] || { echo "queue.sh: no $ckpt to evaluate (python studies/house/kept.py fetch studies/navigate)" >&2
                        exit 2; }
  else
    echo "$(date +%T) training navigate-$t"
    /usr/bin/time -f "%e s from process start" -o "$NAV/train_$t.time" \
      python train.py --task "navigate-$t" --log_dir "$NAV/logs" > "$NAV/train_$t.log" 2>&1
    run=$(ls -d "$NAV/logs/hexnewton_navigate-$t"/*/ | tail -1)
    ckpt="${run}model_result.pt"
    mkdir -p "$NAV/keep" && cp "$ckpt" "$NAV/keep/navigate_$t.pt" && cp "${run}timing.json" "$NAV/keep/timing_$t.json"
    pack "train_$t" "train_$t.log" "train_$t.time" "keep/navigate_$t.pt" "keep/timing_$t.json"
  fi
  echo "$(date +%T) evaluating navigate-$t"
  python -m hexnewton.apps.evaluate --navigate --controllers cpg_rl --checkpoint "cpg_rl=$ckpt" --terrains "$t" \
    --rounds "$ROUNDS" --no-progress --out "$NAV/eval_$t" > "$NAV/eval_$t.log" 2>&1
  python -m hexnewton.apps.export --checkpoint "$ckpt" --out "$NAV/bundle_$t" > "$NAV/export_$t.log" 2>&1
  pack "eval_$t" "eval_$t" "eval_$t.log" "bundle_$t" "export_$t.log"
  [ "$t" = flat ] || continue
  echo "$(date +%T) sim2sim"
  python -m hexnewton.apps.sim2sim "$NAV/bundle_flat" --terrains flat --rounds "$S2S_ROUNDS" --waypoints 2,0 2,2 0,2 \
    0,0 --max_steps 4000 --newton "$NAV/eval_flat/results.json" --workers 0 --out "$NAV/s2s_flat" \
    > "$NAV/s2s_flat.log" 2>&1
  pack s2s_flat s2s_flat s2s_flat.log
done
echo "$(date +%T) queue ended"
