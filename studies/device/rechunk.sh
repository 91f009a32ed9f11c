#!/bin/bash
# Re-split the wheel chunks (.dw0/part0, .dw1/part1, ... from ../shared/device/pack.sh) so that each device call,
# one chunk plus the working tree, stays under the call's 64 MiB: chunk = 64 MiB - the tree - 2 MiB. The tree grows
# with the kept study (studies/paper_comparison), so run this at the start of every lease, from the repository root:
#
#   bash ../shared/device/pack.sh ...    # once per machine, when no .dw* folders exist
#   bash studies/device/aside.sh out     # the studies' data out of the tree: larger chunks, fewer calls
#   bash studies/device/rechunk.sh       # then the device calls it prints
#
# The chunks are joined in name order and split again into .dw0 ... .dwN (install.sh joins /opt/w/part* in name
# order); install.sh moves to the last folder.
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
dirs=$(ls -d .dw[0-9]* 2>/dev/null | sort -V) || true
[ -n "$dirs" ] || { echo "rechunk.sh: no .dw0 .dw1 ... folders: run ../shared/device/pack.sh first" >&2; exit 1; }
install=$(ls $(for d in $dirs; do echo "$d/install.sh"; done) 2>/dev/null | tail -1) || true
[ -n "$install" ] || { echo "rechunk.sh: no install.sh in the .dw* folders" >&2; exit 1; }
# the files a call carries: tracked and untracked-not-ignored ones that exist (a study's data folder set aside for the
# chunk calls, README "Workflow", is not in the tree then)
tree=$(bash studies/device/aside.sh bytes)
# the kept checkpoints fetched into the tree (git ignores them: python studies/house/kept.py fetch) travel in the last
# call's carry, beside its chunk
kept=$(python studies/house/kept.py present)
if [ -n "$kept" ]; then
  [ "$(echo "$kept" | wc -l)" -le 7 ] || { echo "rechunk.sh: more than 7 kept files in the tree (a call carries 8 \
paths): fetch only those the queue reads" >&2; exit 1; }
  tree=$(( tree + $(echo "$kept" | tr '\n' '\0' | xargs -0 du -cb | tail -1 | cut -f1) ))
fi
chunk=$(( 64 * 1048576 - tree - 2 * 1048576 ))
[ "$chunk" -gt 4194304 ] || { echo "rechunk.sh: the tree ($((tree / 1048576)) MiB) leaves no room for wheel chunks: set the \
studies' data aside first (bash studies/device/aside.sh out)" >&2; exit 1; }
work=$(mktemp -d)
cp "$install" "$work/install.sh"
for d in $dirs; do cat "$d"/part*; done > "$work/wheels.tar"
rm -rf $dirs
split -b "$chunk" -d -a 2 "$work/wheels.tar" "$work/part"
n=0
for part in $(ls "$work"/part* | sort -V); do
  mkdir -p ".dw$n" && mv "$part" ".dw$n/part$(printf %02d $n)"
  n=$((n + 1))
done
last=".dw$((n - 1))"
mv "$work/install.sh" "$last/install.sh"
rm -rf "$work"
echo "tree $((tree / 1048576)) MiB: $n chunks of at most $((chunk / 1048576)) MiB. Device calls, back to back:"
if [ "$n" = 1 ]; then   # one chunk: its call installs too
  echo "  run carry=[\".dw0\"$(for k in $kept; do printf ', "%s"' "$k"; done)]  command: rm -rf /opt/w && mkdir -p /opt/w && \
cp .dw0/part* /opt/w/ && bash studies/device/gpu.sh install && ..."
  exit 0
fi
echo "  run carry=[\".dw0\"]  command: rm -rf /opt/w && mkdir -p /opt/w && cp .dw0/part* /opt/w/"
for i in $(seq 1 $((n - 1))); do
  if [ ".dw$i" = "$last" ]; then
    echo "  run carry=[\"$last\"$(for k in $kept; do printf ', "%s"' "$k"; done)]  command: cp $last/part* /opt/w/ && \
bash studies/device/gpu.sh install && ..."
  else
    echo "  run carry=[\".dw$i\"]  command: cp .dw$i/part* /opt/w/"
  fi
done
