#!/bin/bash
# A queue for one H200 (`bash studies/device/gpu.sh queue studies/throughput/solver_ab.sh`): the solver settings that
# could cut the complex step's dominant part (MuJoCo-Warp's solver, 68.5 % of its GPU time: profile/), each against
# the default settings (SimConfig) on the same machine:
# 1. the physics alone, each variant alone on the GPU, one after another (bench --mode sim, 16384 envs, the complex,
#    rugged and stepped courses) -> $TP/ab/sim_VARIANT.json;
# 2. the A/B: the shipped policy and the fixed CPG on 1000 test rounds per terrain (the evaluate default seed) under
#    each variant's physics, all at once -> $TP/ab/eval_VARIANT_TERRAIN/ (a variant is kept only with success within 1
#    point and falls before the goal within 0.5 points of the base's, on every terrain).
# VARIANTS (default: every variant of solver_ab.py FLAGS) picks some; EVAL_VARIANTS (default: VARIANTS) the ones whose
# A/B rounds run (a short lease: the physics of all, the rounds of the likeliest). Then from the next call:
# `bash studies/device/gpu.sh poll 500` and `tar czf $OUT/ab.tgz -C /root/throughput ab`; here the tarball's ab/ becomes
# studies/throughput/solver_ab/raw/DATE/ and `python studies/throughput/solver_ab.py` writes the report.
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site:$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput}
mkdir -p "$TP/ab"
flags() { python studies/throughput/solver_ab.py --flags "$1"; }   # a variant's flags (solver_ab.py FLAGS)
VARIANTS=${VARIANTS:-base iter5 ls4 cg sub3 sub2 rows192}
for v in $VARIANTS ${EVAL_VARIANTS:-}; do flags "$v" > /dev/null || exit 2; done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$TP/ab/gpu.txt"
for v in $VARIANTS; do
  echo "$(date +%T) sim $v"
  # shellcheck disable=SC2046  # the variant's flags are words
  python -m hexnewton.apps.bench --device cuda --num_envs 16384 --mode sim --frames 200 --env.sim.frame_dt 0.02 \
    --env.sim.substeps 4 --terrain complex rugged stepped $(flags "$v") --json "$TP/ab/sim_$v.json" \
    > "$TP/ab/sim_$v.log" 2>&1; echo "exit $?" >> "$TP/ab/sim_$v.log"
done
for v in ${EVAL_VARIANTS:-$VARIANTS}; do
  for t in complex rugged stepped; do
    # shellcheck disable=SC2046
    python -m hexnewton.apps.evaluate --controllers cpg cpg_rl --checkpoint cpg_rl=results/policies/cpg_rl_complex.pt \
      --terrains "$t" --rounds 1000 $(flags "$v") --out "$TP/ab/eval_${v}_$t" --no-progress \
      > "$TP/ab/eval_${v}_$t.log" 2>&1 &
  done
done
wait
echo "$(date +%T) done"
