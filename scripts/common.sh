# Shared by demo.sh and test.sh: set up, configure and build (Release).
# Usage: source scripts/common.sh; lookboth_build <targets...>
set -euo pipefail

LOOKBOTH_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
LOOKBOTH_BUILD_DIR=${LOOKBOTH_BUILD_DIR:-"$LOOKBOTH_ROOT/build"}
LOOKBOTH_JOBS=${LOOKBOTH_JOBS:-$(nproc 2>/dev/null || echo 2)}

lookboth_build() {
  "$LOOKBOTH_ROOT/scripts/setup.sh"
  local generator=()
  if command -v ninja >/dev/null 2>&1 && [[ ! -f "$LOOKBOTH_BUILD_DIR/Makefile" ]]; then
    generator=(-G Ninja)
  fi
  # LOOKBOTH_BUILD_BENCHMARKS=OFF leaves the benchmark programs out (CI:
  # .ci/run); they are built by default and by scripts/bench_*.sh.
  cmake -S "$LOOKBOTH_ROOT" -B "$LOOKBOTH_BUILD_DIR" "${generator[@]}" \
    -DCMAKE_BUILD_TYPE=Release -DLOOKBOTH_WERROR=ON \
    "-DLOOKBOTH_BUILD_BENCHMARKS=${LOOKBOTH_BUILD_BENCHMARKS:-ON}" >/dev/null
  cmake --build "$LOOKBOTH_BUILD_DIR" --parallel "$LOOKBOTH_JOBS" ${1:+--target "$@"}
}
