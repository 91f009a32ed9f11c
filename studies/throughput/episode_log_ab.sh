#!/bin/bash
# A queue for one H200 (`bash studies/device/gpu.sh queue studies/throughput/episode_log_ab.sh`), each call alone on
# the GPU: training against the physics alone, the complex task at 4096 and 16384 envs, with rsl-rl's own per-step
# episode bookkeeping (three host reads a step) and with the deferred one (`--agent.deferred_episode_log`, the
# default), in the order off, on, off, on (the machine warms through the first) -> $TP/episode_log/{off,on}_N.{json,md}.
# Then from the next call: `bash studies/device/gpu.sh poll 500` and `tar czf $OUT/episode_log.tgz -C $TP episode_log`.
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput}
out=$TP/episode_log
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
git rev-parse HEAD > "$out/revision.txt" 2>/dev/null
for n in 1 2; do
  for mode in off on; do
    flag=$([ "$mode" = on ] && echo true || echo false)
    echo "$(date +%T) $mode $n"
    python -m hexnewton.apps.bench --task complex --num_envs ${NUM_ENVS:-4096 16384} --mode sim env train \
      --agent.deferred_episode_log "$flag" --json "$out/${mode}_$n.json" --append "$out/${mode}_$n.md" \
      > "$out/${mode}_$n.log" 2>&1
    echo "exit $?" >> "$out/${mode}_$n.log"
  done
done
echo "$(date +%T) done"
