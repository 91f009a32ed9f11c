#!/bin/bash
# The layout's measures at a commit (default HEAD): results/'s files, bytes and reports, the documents' lengths, the
# package's command-line and analysis modules, the files under studies/.
set -euo pipefail
rev=${1:-HEAD}
echo "results files:   $(git ls-tree -r "$rev" results | wc -l)"
echo "results bytes:   $(git ls-tree -r -l "$rev" results | awk '{s += $4} END {print s + 0}')"
echo "results reports: $(git ls-tree -r --name-only "$rev" results | grep -c 'report.md$' || true)"
echo "time_to_skill reports: $(git ls-tree -r --name-only "$rev" results/time_to_skill | grep -c 'report.md$' || true)"
for f in RESULTS.md BENCHMARKS.md README.md; do echo "$f lines: $(git show "$rev:$f" | wc -l)"; done
echo "apps + analysis modules: $(git ls-tree -r --name-only "$rev" hexnewton/apps hexnewton/analysis | grep -c '\.py$')"
echo "studies files:   $(git ls-tree -r --name-only "$rev" studies | wc -l)"
