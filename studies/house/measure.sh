#!/bin/bash
# The layout's measures at a commit (default HEAD), as one JSON object: files, bytes and report.md files under
# results/ and studies/, the documents' lengths, the package's modules and lines, scripts/ and tests/.
#   bash studies/house/measure.sh e25a56a      # before
#   bash studies/house/measure.sh HEAD         # now
set -euo pipefail
cd "$(dirname "$0")/../.."
rev=${1:-HEAD}
git rev-parse --verify -q "$rev^{commit}" > /dev/null || { echo "measure.sh: no commit $rev" >&2; exit 2; }
files() { git ls-tree -r --name-only "$rev" -- "$@" | grep -c . || true; }
bytes() { git ls-tree -r -l "$rev" -- "$@" | awk '{s += $4} END {print s + 0}'; }
reports() { git ls-tree -r --name-only "$rev" -- "$@" | grep -c 'report\.md$' || true; }
lines() { local n=0 f; for f in $(git ls-tree -r --name-only "$rev" -- "$@" | grep '\.py$' || true); do
  n=$((n + $(git show "$rev:$f" | wc -l))); done; echo $n; }
doc() { git show "$rev:$1" 2>/dev/null | wc -l; }
cat <<JSON
{"rev": "$(git rev-parse --short "$rev")",
 "results": {"files": $(files results), "bytes": $(bytes results), "reports": $(reports results),
             "folders": $(git ls-tree --name-only "$rev" results/ | grep -vc '^results/README.md$' || true)},
 "studies": {"files": $(files studies), "bytes": $(bytes studies), "reports": $(reports studies),
             "folders": $(git ls-tree -d --name-only "$rev" studies/ 2>/dev/null | grep -c . || true)},
 "documents_lines": {"RESULTS.md": $(doc RESULTS.md), "BENCHMARKS.md": $(doc BENCHMARKS.md), "README.md": $(doc README.md)},
 "package": {"modules": $(git ls-tree -r --name-only "$rev" hexnewton | grep -c '\.py$'), "lines": $(lines hexnewton),
             "apps_analysis_modules": $(git ls-tree -r --name-only "$rev" hexnewton/apps hexnewton/analysis | grep -c '\.py$'),
             "apps_analysis_lines": $(lines hexnewton/apps hexnewton/analysis)},
 "scripts_files": $(files scripts), "tests": {"files": $(files tests), "lines": $(lines tests)},
 "repository": {"files": $(files .), "bytes": $(bytes .)}}
JSON
