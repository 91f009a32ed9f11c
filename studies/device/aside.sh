#!/bin/bash
# The studies' kept data (checkpoints, curves, evaluations) out of the working tree and back: the tree that a device
# call sends must stay under 64 MiB with a wheel chunk beside it: the smaller the tree, the larger the chunks.
#
#   bash studies/device/aside.sh out     # the folders below to $ASIDE (default ../device_aside), then the tree's size
#   bash studies/device/aside.sh back    # them back into the tree
#   bash studies/device/aside.sh size    # the tree's size as a device call counts it (bytes: in bytes, rechunk.sh's)
#
# `out` before rechunk.sh and the device calls; `back` before anything that reads a study's data (its tests, build.py,
# a commit). A queue that reads a kept study's files (`gpu.sh study studies/paper_comparison`) needs that folder in
# the tree: KEEP="studies/paper_comparison" leaves it there. The kept checkpoints (KEPT=, TEST_KEPT= for
# studies/learner/runs, navigate's TRAINED=, capability.sh's seeds) come from git history: python
# studies/house/kept.py fetch FOLDER (KEEP= the folder they are in), rechunk.sh carries them.
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
ASIDE=${ASIDE:-../device_aside}
FOLDERS=${FOLDERS:-studies/paper_comparison studies/capability studies/training_curves studies/time_to_skill \
studies/sim2sim studies/scale_out studies/learner/runs}
tree_bytes() {   # tracked and untracked-not-ignored files that exist (what a device call sends; du skips the rest)
  (git ls-files -z; git ls-files -z --others --exclude-standard) | xargs -0 du -cb 2>/dev/null | tail -1 | cut -f1 \
    || true
}
case "${1:-}" in
out)
  moved=""
  for f in $FOLDERS; do
    case " ${KEEP:-} " in *" $f "*) continue;; esac
    [ -e "$f" ] || continue
    [ -e "$ASIDE/$f" ] && { echo "aside.sh: $ASIDE/$f exists already: 'aside.sh back' first" >&2; exit 1; }
    mkdir -p "$ASIDE/$(dirname "$f")" && mv "$f" "$ASIDE/$f" && moved="$moved $f"
  done
  echo "tree $(( $(tree_bytes) / 1048576 )) MiB, set aside in $ASIDE:${moved:- nothing}"
  ;;
back)
  for f in $FOLDERS; do
    [ -e "$ASIDE/$f" ] || continue
    [ -e "$f" ] && { echo "aside.sh: $f is in the tree and in $ASIDE: left as it is" >&2; continue; }
    mkdir -p "$(dirname "$f")" && mv "$ASIDE/$f" "$f"
  done
  echo "tree $(( $(tree_bytes) / 1048576 )) MiB"
  ;;
size)
  echo "tree $(( $(tree_bytes) / 1048576 )) MiB"
  ;;
bytes)
  tree_bytes
  ;;
*)
  echo "usage: bash studies/device/aside.sh out|back|size|bytes" >&2; exit 2
  ;;
esac
