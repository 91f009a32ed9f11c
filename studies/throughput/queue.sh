#!/bin/bash
# A queue for one H200 (`bash studies/device/gpu.sh queue studies/throughput/queue.sh`), each command alone on the GPU:
# 1. start-up, warm: `python train.py --task complex --max_iterations 2 --agent.validation_rounds 0` twice (the first
#    also fills the kernel cache where the machine is fresh), each run's timing.json -> $TP/start_N/;
# 2. the complex control step's profile (frame_profile.py, 16384 and 4096 envs) -> $TP/profile_N/;
# 3. the physics alone and training against it at 4096 and 16384 envs (one bench call) -> $TP/bench.{json,md}.
# Then from the next call: `bash studies/device/gpu.sh poll 500 '/root/throughput'`.
set -u
cd "$(dirname "$0")/../.."
# $PWD: the study scripts import the tree
export PYTHONPATH=/opt/site:$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput}
mkdir -p "$TP"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$TP/gpu.txt"
for n in 1 2; do
  echo "$(date +%T) start-up $n"
  python train.py --task complex --max_iterations 2 --agent.validation_rounds 0 --log_dir "$TP/start_$n" \
    --experiment warm > "$TP/start_$n.log" 2>&1; echo "exit $?" >> "$TP/start_$n.log"
  cp "$(ls -d "$TP/start_$n"/warm/*/ | tail -1)timing.json" "$TP/start_$n.timing.json" 2>/dev/null
done
for n in 16384 4096; do
  echo "$(date +%T) profile $n"
  python studies/throughput/frame_profile.py --task complex --num_envs "$n" --out "$TP/profile_$n" \
    > "$TP/profile_$n.log" 2>&1; echo "exit $?" >> "$TP/profile_$n.log"
done
if [ "${BENCH:-1}" = 1 ]; then
  echo "$(date +%T) bench"
  python -m hexnewton.apps.bench --task complex --num_envs 4096 16384 --mode sim env train --profile \
    --json "$TP/bench.json" --append "$TP/bench.md" > "$TP/bench.log" 2>&1; echo "exit $?" >> "$TP/bench.log"
fi
rm -rf "$TP"/start_1 "$TP"/start_2
echo "$(date +%T) done"
