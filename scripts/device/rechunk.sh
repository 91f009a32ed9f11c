#!/bin/bash
# Halve the chunks of ../shared/device/pack.sh so each device call carries ~26 MB instead of ~51 MB.
# A call carries the working tree as well (64 MiB in all), and the tree has grown past 14 MB:
# one 51 MB chunk plus the tree was 63.7 MiB. Run right after pack.sh, from the repository root:
#
#   bash ../shared/device/pack.sh && bash scripts/device/rechunk.sh
#
# .dwN/partN becomes .dwNa/partNa and .dwNb/partNb (install.sh joins /opt/w/part* in name order, so the
# order is kept); install.sh moves to the last folder. Prints the device calls to make.
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
dirs=$(ls -d .dw[0-9] 2>/dev/null | sort -V) || true
[ -n "$dirs" ] || { echo "rechunk.sh: no .dw0 .dw1 ... folders: run ../shared/device/pack.sh first" >&2; exit 1; }
last=""
for d in $dirs; do
  part=$(ls "$d"/part*)
  size=$(stat -c %s "$part")
  split -b $(( (size + 1) / 2 )) -a 1 "$part" "$part"     # partN -> partNa, partNb
  for half in a b; do mkdir -p "${d}${half}"; mv "${part}${half}" "${d}${half}/"; done
  [ -f "$d/install.sh" ] && mv "$d/install.sh" "${d}b/install.sh" && last="${d}b"
  rm -rf "$d"
done
echo "Make these device calls back to back (the machine is given back 30 s after a call ends):"
for d in $(ls -d .dw[0-9][ab] | sort -V); do
  if [ "$d" = "$last" ]; then
    echo "  run carry=[\"$d\", ...] command: cp $d/part* /opt/w/ && bash $d/install.sh && export PYTHONPATH=/opt/site && YOUR COMMAND"
  else
    echo "  run carry=[\"$d\"]  command: mkdir -p /opt/w && cp $d/part* /opt/w/"
  fi
done
