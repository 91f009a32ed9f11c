#!/bin/bash
# A queue for one GPU (`bash studies/device/gpu.sh queue studies/startup_beside/scene_first.sh`): scene_first.py there,
# 2 runs per mode alternating (~2 min) -> $TP/scene_first/{results.json,report.md}. Then from the next call:
# `tar czf $OUT/scene_first.tgz -C $TP scene_first`; here the folder becomes studies/startup_beside/scene_first_gpu/.
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site:$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput}
mkdir -p "$TP"
echo "$(date +%T) scene_first"
python studies/startup_beside/scene_first.py --runs 2 --device cuda --out "$TP/scene_first" > "$TP/scene_first.log" 2>&1
echo "exit $?" >> "$TP/scene_first.log"
echo "$(date +%T) done"
