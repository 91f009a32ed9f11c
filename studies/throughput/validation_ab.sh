#!/bin/bash
# A queue for one GPU (`HEXNEWTON_GIT_REV=COMMIT bash studies/device/gpu.sh queue studies/throughput/validation_ab.sh`,
# COMMIT the tree's commit, `git rev-parse --short HEAD` here: a device call's tree has no history, and git_rev reads
# it): validation_ab.py, the courses one by one against side by side, $REPEATS (default 1) runs of each, ~3 min per
# repeat on one H100 ->
# $TP/validation_ab/{raw.json,report.md,results.json}. Then from the next call:
# `tar czf $OUT/validation_ab.tgz -C $TP validation_ab`; here it becomes studies/throughput/validation/.
set -u
cd "$(dirname "$0")/../.."
export PYTHONPATH=/opt/site:$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
TP=${TP:-/root/throughput}
mkdir -p "$TP"
echo "$(date +%T) validation_ab"
python studies/throughput/validation_ab.py --out "$TP/validation_ab" --repeats "${REPEATS:-1}" \
  > "$TP/validation_ab.log" 2>&1
echo "exit $?" >> "$TP/validation_ab.log"
echo "$(date +%T) done"
