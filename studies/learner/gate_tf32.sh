#!/bin/bash
# The learner's gate with TF32 (`--agent.tf32 true`: studies/throughput/tf32, +10 % training at 16384 envs) as one
# queue on one GPU, after the chunk calls and `gpu.sh install`
# (`bash studies/device/gpu.sh queue studies/learner/gate_tf32.sh`):
# its seeds $GATE_SEEDS (default 2 3: seed 1 is kept in studies/learner/runs/gate_tf32_s1) one after another, alone,
# then their 1000 test rounds per course with the shipped policy and the fixed CPG; then the kept seeds' ($TEST_KEPT,
# default gate_tf32_s1: their runs/NAME/policy.pt in the tree) test rounds. ~14 min on one H100. Then
# `bash studies/device/learner.sh collect` and here `python studies/learner/build.py --add LEASE`.
set -u
cd "$(dirname "$0")/../.."
LEARNER=${LEARNER:-studies/device/learner.sh}
flags=$(python3 studies/learner/build.py --flags tf32) || exit 2
ARMS= KEPT= GATE=1 GATE_SEEDS="${GATE_SEEDS:-2 3}" GATE_NAME=gate_tf32 GATE_FLAGS="$flags" bash "$LEARNER"
test_kept=${TEST_KEPT-gate_tf32_s1}
[ -z "$test_kept" ] || ARMS= KEPT= GATE=0 TEST_KEPT="$test_kept" bash "$LEARNER"
