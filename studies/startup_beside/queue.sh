#!/bin/bash
# A queue for one GPU (`bash studies/device/gpu.sh queue studies/startup_beside/queue.sh`): each A/B of $STEPS (default
# "scene_first preload": scene_first.py, ~2 min; preload.py, train.py to its first iteration, ~4 min) there, the complex
# task at 4096 envs, one warm-up run kept apart, then 2 runs per mode alternating -> $TP/<step>/{results.json,
# report.md}; "gil" (gil.py, ~1 min: the finalize and the interpreter lock, the imports alone; HEXNEWTON_GIT_REV=COMMIT
# names the tree's commit). Then from the next call:
# `tar czf $OUT/startup.tgz -C $TP scene_first preload`; here each folder becomes studies/startup_beside/<step>_gpu/.
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site:$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput}
mkdir -p "$TP"
for step in ${STEPS:-scene_first preload}; do
  echo "$(date +%T) $step"
  case $step in
    gil) args=(--device cuda);;   # one measurement
    *) args=(--runs 2 --warmup 1 --device cuda);;   # the machine's first process pays for its caches: apart
  esac
  python "studies/startup_beside/$step.py" "${args[@]}" --out "$TP/$step" > "$TP/$step.log" 2>&1
  echo "exit $?" >> "$TP/$step.log"
done
echo "$(date +%T) done"
