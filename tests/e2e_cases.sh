# Sourced by the end-to-end case scripts (tests/*/cases.sh): their arguments
# and a fresh work folder.
#   source e2e_cases.sh <lookboth binary> <case> <work dir>
# Sets L, CASE, WORK and SHARE (LOOKBOTH_SHARE_DIR, else the source tree's),
# enters a new empty WORK, and defines fail.
set -euo pipefail
L=$1
CASE=$2
WORK=$3
SHARE=${LOOKBOTH_SHARE_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/../share/lookboth" && pwd)}
rm -rf "$WORK"
mkdir -p "$WORK"
cd "$WORK"

fail() {
  echo "FAIL: $*" >&2
  exit 1
}
