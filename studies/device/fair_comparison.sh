#!/bin/bash
# A queue (`bash studies/device/gpu.sh queue studies/device/fair_comparison.sh`) for one H200: the paper comparison's
# rows on equal terms (studies/paper_comparison, "Equal terms"):
# - pure DRL with the stable-gait curriculum's reward stages (`joint_staged`: task complex-joint-staged), seeds 1-3,
#   60 M env-steps at 4096 envs or 20 minutes, two runs at a time on the one GPU, the third as one of them ends;
# - the fixed CPG on the policies' physics (`cpg_frame20`: 20 ms frame, 4 substeps), 1000 rounds per terrain, started
#   at once beside the runs, then every finished run's deterministic and sampled action (1000 rounds per terrain);
# what the kept study holds already is skipped.
# Then, from the next call: `bash studies/device/gpu.sh poll 560 && bash studies/device/gpu.sh collect`; here:
# `python studies/paper_comparison/compare.py --study studies/paper_comparison --add LEASE/methods LEASE/method_evals`.
set -u
cd "$(dirname "$0")/../.."
# the kept study first: its finished runs and evaluations are skipped
bash studies/device/gpu.sh study studies/paper_comparison
JOBS="${JOBS:-joint_staged:1 joint_staged:2 joint_staged:3}" bash studies/device/gpu.sh methods complex 20 60000000 \
  4096 "" "0 0"
sleep 5
FIXED_CPG=cpg_frame20 PER_GPU=${PER_GPU:-8} EVAL_TIMEOUT=${EVAL_TIMEOUT:-1500} \
  bash studies/device/gpu.sh evals 1000 "0" rugged stepped complex
sleep 30
while bash studies/device/gpu.sh busy; do sleep 10; done
echo "$(date +%T) the queue's runs and evaluations ended"
