#!/usr/bin/env bash
# Checks that no function of the project's libraries and apps (tests,
# benchmarks and fuzz targets aside) is longer than a limit (default 200
# lines, about two screens: doc/architecture.md, "Code"): prints those that
# are, longest first, and exits 1. Lengths come from universal-ctags' end
# lines; a lambda counts toward the function that holds it.
#   scripts/check-function-length.sh [limit]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
limit=${1:-200}
if ! ctags --version 2>/dev/null | grep -q "Universal Ctags"; then
  echo "check-function-length.sh: universal-ctags is missing (scripts/setup.sh installs it)" >&2
  exit 2
fi
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files 'libs/*.cpp' 'libs/*.h' 'apps/*.cpp' 'apps/*.h')
else
  mapfile -t files < <(find apps libs -name '*.cpp' -o -name '*.h' | sort)
fi
mapfile -t files < <(printf '%s\n' "${files[@]}" | grep -v -e '/tests/' -e '/benchmarks/' -e '/fuzz/')
long=$(ctags --languages=C++ --c++-kinds=f --fields=+ne -o - "${files[@]}" 2>/dev/null |
  awk -F'\t' -v limit="$limit" '{
      line = ""; end = ""
      for (i = 4; i <= NF; ++i) {
        if ($i ~ /^line:/) line = substr($i, 6)
        if ($i ~ /^end:/) end = substr($i, 5)
      }
      if (end != "" && end - line + 1 > limit) printf "%5d  %s:%s  %s\n", end - line + 1, $2, line, $1
    }' | sort -rn)
if [[ -n $long ]]; then
  echo "check-function-length.sh: functions longer than $limit lines (split them into named steps):" >&2
  echo "$long" >&2
  exit 1
fi
echo "check-function-length.sh: ${#files[@]} files, no function longer than $limit lines"
