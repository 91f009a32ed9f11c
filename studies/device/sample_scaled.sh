#!/bin/bash
# The sample-scaled recipe and the 4-GPU seeds (studies/device/README.md, "A lease's work as one queue") as one queue,
# from a copy of the tree (the README's first line), after the chunk calls and `gpu.sh install`:
#
#   bash studies/device/gpu.sh queue studies/device/sample_scaled.sh
#   bash studies/device/gpu.sh poll 560 '/root/cand/*'     # the next call at once: item 1's archives
#   bash studies/device/gpu.sh poll 560 '/root/so_out/*'   # then until "item 2 ended"
#
# 1. What `g4cmi600` computes, on one GPU ($RECIPE: 16384 envs, 8 mini-batches, 150 iterations, the stages at 25 and
#    50, a checkpoint every 13 iterations, two lanes a goal), seeds 1-3, and the recipe's seed 1 beside them, one run
#    per GPU on validation rounds (`candidates.sh`; on fewer than 4 GPUs two at a time) -> $CAND (default /root/cand:
#    the run archives and evals.tgz; on fewer GPUs evals_a.tgz and evals_b.tgz, one per round).
# 2. On 4 GPUs, then: the scale-out runs (`scale_out.sh`: the one-GPU recipe alone, `g4cmi600` on seeds 2 and 3),
#    their test rounds, packed -> $SO_OUT (default /root/so_out).
set -u
here=$(cd "$(dirname "$0")" && pwd)
gpus=$(nvidia-smi -L | grep -c '^GPU')
S="((25,{'posture_reflex':2.0,'w_tilt':15.0,'w_ang_vel':0.1}),(50,{'w_tilt':40.0,'w_ang_vel':0.3}))"
RECIPE=${RECIPE:-"--task complex --num_envs 16384 --max_iterations 150 --agent.save_interval 13 --env.terrain.climb 2 \
--agent.algorithm.num_mini_batches 8 --agent.stages $S"}
BASE=${BASE:-"--task complex --num_envs 4096"}
CAND=${CAND:-/root/cand} SO_OUT=${SO_OUT:-/root/so_out}
export LIMIT=${LIMIT:-560} S2S_ROUNDS=${S2S_ROUNDS-300} S2S_WORKERS=${S2S_WORKERS:-12}
echo "$(date +%T) sample_scaled.sh on $gpus GPUs"
if [ "$gpus" -ge 4 ]; then
  OUT=$CAND bash "$here/candidates.sh" "rep1@0:$RECIPE --seed 1" "rep2@1:$RECIPE --seed 2" \
    "rep3@2:$RECIPE --seed 3" "recipe1@3:$BASE --seed 1"
else
  OUT=$CAND bash "$here/candidates.sh" "rep1@0:$RECIPE --seed 1" "rep2@$((gpus > 1)):$RECIPE --seed 2"
  mv "$CAND/evals.tgz" "$CAND/evals_a.tgz"
  OUT=$CAND EVALS=${EVALS:-/root/evals}_b bash "$here/candidates.sh" "rep3@0:$RECIPE --seed 3" \
    "recipe1@$((gpus > 1)):$BASE --seed 1"
  mv "$CAND/evals.tgz" "$CAND/evals_b.tgz"
fi
echo "$(date +%T) item 1 ended"
[ "$gpus" -ge 4 ] || exit 0
export OUT=$SO_OUT
ROUNDS="g1x4096:0:4096" bash "$here/scale_out.sh" train
for s in 2 3; do
  ROUNDS="g4cmi600s$s:0,1,2,3:4096:mini_batches,iterations" \
    TRAIN_ARGS="--max_iterations 600 --env.terrain.climb 2 --seed $s" bash "$here/scale_out.sh" train
done
bash "$here/scale_out.sh" eval && bash "$here/scale_out.sh" pack
echo "$(date +%T) item 2 ended"
