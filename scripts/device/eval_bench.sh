#!/bin/bash
# Table 3 and the benchmarks on a 2-GPU machine, one device call: GPU 0 runs the benchmark table (then trains the pure-DRL
# `joint` controller on flat ground until the deadline, for Fig. 5a); GPU 1 runs the paper's evaluation
# (25 rounds, then 1000) of fixed CPG and CPG_RL on rugged, stepped and complex terrain.
#
#   RUGGED=/root/keep/rugged.pt STEPPED=... COMPLEX=... DEADLINE_S=560 bash scripts/device/eval_bench.sh
#
# Results under $OUT: BENCHMARKS.md (the appended table), bench.json, bench.log, eval.tgz (eval25/ eval1000/:
# report.md, results.json, figures), run_joint.tgz.
set -u
OUT=${OUT:-out}
START=${START_S:-0}
DEADLINE=${DEADLINE_S:-560}
mkdir -p "$OUT"
export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader | tee "$OUT/gpu.txt"
(
  export CUDA_VISIBLE_DEVICES=0
  t=$SECONDS
  python -m hexnewton.bench --device cuda --num_envs 1024 4096 16384 --terrain flat complex --mode sim env train \
    --append "$OUT/BENCHMARKS.md" --json "$OUT/bench.json" > "$OUT/bench.log" 2>&1
  echo "bench: $((SECONDS - t)) s, exit $?" >> "$OUT/bench.log"
  left=$((DEADLINE - START - SECONDS - 40))
  if [ "$left" -gt 60 ]; then
    SKIP_WARMUP=1 START_S=$((START + SECONDS)) DEADLINE_S=$DEADLINE OUT="$OUT" \
      bash scripts/device/train_runs.sh "joint:--terrain flat --action_mode joint --seed 1" > "$OUT/joint.log" 2>&1
  fi
) &
(
  export CUDA_VISIBLE_DEVICES=1
  ck="--checkpoint cpg_rl:rugged=$RUGGED cpg_rl:stepped=$STEPPED cpg_rl:complex=$COMPLEX"
  for r in 25 1000; do
    t=$SECONDS
    python -m hexnewton.evaluate --controllers cpg cpg_rl $ck --terrains rugged stepped complex --rounds $r \
      --out "/root/eval$r" --no-progress > "/root/eval$r.log" 2>&1
    echo "eval $r rounds: $((SECONDS - t)) s, exit $?" >> "/root/eval$r.log"
    mkdir -p "/root/eval$r" && mv "/root/eval$r.log" "/root/eval$r/"
  done
  tar czf "$OUT/eval.tgz" -C /root eval25 eval1000
) &
wait
tail -3 "$OUT/bench.log"; cat /root/eval25/report.md 2>/dev/null | head -40; cat /root/eval1000/report.md 2>/dev/null | head -40
