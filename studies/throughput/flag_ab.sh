#!/bin/bash
# A queue for one H200 (`AB=NAME bash studies/device/gpu.sh queue studies/throughput/flag_ab.sh`), each call alone on
# the GPU: training against the physics alone, the complex task at 4096 and 16384 envs, with a learner switch off and
# on (flag_ab.py ABS: AB=episode_log, rsl-rl's per-step episode bookkeeping against the deferred one; AB=tf32, full
# float32 matrix products against TF32), in the order off, on, off, on (the machine warms through the first)
# -> $TP/NAME/{off,on}_N.{json,md,log}. Then from the next call: `bash studies/device/gpu.sh poll 500` and
# `tar czf $OUT/NAME.tgz -C $TP NAME`; here the tarball's NAME/ becomes studies/throughput/NAME/raw/DATE/ and
# `python studies/throughput/flag_ab.py NAME` writes the report.
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput} AB=${AB:-episode_log}
args=$(python3 studies/throughput/flag_ab.py --bench "$AB") || exit 2   # off's arguments, then on's
out=$TP/$AB
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
git rev-parse HEAD > "$out/revision.txt" 2>/dev/null
for n in 1 2; do
  for mode in off on; do
    echo "$(date +%T) $AB $mode $n"
    line=$([ "$mode" = off ] && sed -n 1p <<< "$args" || sed -n 2p <<< "$args")
    # shellcheck disable=SC2086  # the bench's arguments are words
    python -m hexnewton.apps.bench $line --json "$out/${mode}_$n.json" --append "$out/${mode}_$n.md" \
      > "$out/${mode}_$n.log" 2>&1
    echo "exit $?" >> "$out/${mode}_$n.log"
  done
done
echo "$(date +%T) done"
