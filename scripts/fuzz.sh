#!/usr/bin/env bash
# Builds and runs lookboth's libFuzzer targets (doc/reliability.md, "Fuzzing
# and sanitizers").
#
#   scripts/fuzz.sh <target> <seconds> [libFuzzer flags...]   one target
#   scripts/fuzz.sh <t1,t2,...> <seconds> [libFuzzer flags...] those, in turn
#   scripts/fuzz.sh all <seconds> [libFuzzer flags...]        each target in turn
#   scripts/fuzz.sh list                                      the targets
#
# Builds with clang in $LOOKBOTH_SANITIZE_BUILD_DIR (default build-sanitize:
# ASan + UBSan + libFuzzer coverage; the tree scripts/test.sh --sanitize runs
# the unit tests in), writes the target's seed corpus (share/lookboth,
# tests/data and samples made by lookboth-fuzz-seeds) into a temporary folder,
# runs the target for <seconds> and prints the outcome. Inputs that crash,
# time out (10 s) or run out of memory (2 GB) are saved under
# $LOOKBOTH_FUZZ_FINDINGS/<target>/ (default <build dir>/fuzz-findings).
# Exits non-zero when any target found something.
#
# Sourced (by scripts/test.sh), it only defines the sanitizer build's helpers.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

LOOKBOTH_SANITIZE_BUILD_DIR=${LOOKBOTH_SANITIZE_BUILD_DIR:-"$LOOKBOTH_ROOT/build-sanitize"}

# Configures the sanitizer tree: clang when there is one (then the fuzz
# targets are in it too), else the default compiler with sanitizers only.
# -O1 keeps the build and the runs fast enough for CI; NDEBUG as in the
# Release build (and Ceres's headers need glog linked without it); -g1 (line
# tables) gives file:line in the reports. Warnings are not errors here: the
# Release build (gcc) enforces the project's warning set, and clang has
# warnings of its own (the fuzz targets keep -Werror).
lookboth_sanitize_configure() {
  "$LOOKBOTH_ROOT/scripts/setup.sh"
  local args=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG"
    -DLOOKBOTH_WERROR=OFF -DLOOKBOTH_BUILD_BENCHMARKS=OFF -DLOOKBOTH_SANITIZE=ON)
  if [[ ! -f "$LOOKBOTH_SANITIZE_BUILD_DIR/CMakeCache.txt" ]]; then
    if command -v ninja >/dev/null 2>&1; then args+=(-G Ninja); fi
    if command -v clang++ >/dev/null 2>&1; then
      args+=(-DCMAKE_CXX_COMPILER=clang++ -DLOOKBOTH_FUZZ=ON)
    fi
  fi
  cmake -S "$LOOKBOTH_ROOT" -B "$LOOKBOTH_SANITIZE_BUILD_DIR" "${args[@]}" >/dev/null
}

lookboth_sanitize_fuzz_enabled() {
  grep -q '^LOOKBOTH_FUZZ:BOOL=ON' "$LOOKBOTH_SANITIZE_BUILD_DIR/CMakeCache.txt"
}

# Writes the sanitizers' runtime options (exported ASAN_OPTIONS, UBSAN_OPTIONS,
# LSAN_OPTIONS) for the tests and the fuzz targets.
lookboth_sanitize_environment() {
  local suppressions="$LOOKBOTH_SANITIZE_BUILD_DIR/lsan.supp"
  # LeakSanitizer suppressions: third-party libraries only, never lookboth's
  # code. Each matches an allocation made inside that library.
  cat >"$suppressions" <<'EOF'
# Mesa's EGL/GL drivers (MRPT's off-screen rendering in libs/report) keep
# driver state allocated until the process exits by design.
leak:libEGL_mesa.so
leak:libGLX_mesa.so
leak:libgallium
leak:swrast_dri.so
leak:libLLVM
# fontconfig and FreeType caches filled by MRPT's text rendering, never freed.
leak:libfontconfig.so
leak:libfreetype.so
EOF
  local symbolizer
  symbolizer=$(command -v llvm-symbolizer || true)
  export ASAN_OPTIONS="detect_leaks=1:check_initialization_order=1:strict_init_order=1${symbolizer:+:external_symbolizer_path=$symbolizer}"
  export LSAN_OPTIONS="suppressions=$suppressions:print_suppressions=0"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${symbolizer:+:external_symbolizer_path=$symbolizer}"
  # sim/render's pose study renders 36 frames at 1920x1080 with supersampling
  # (99 s in Release): more than an hour under the sanitizers. Three frames per
  # camera height run the same code and still meet its bounds (two do not:
  # the median SUBPIX position error is then 1.67 cm, above 1.5).
  export LOOKBOTH_RENDER_MARKER_FRAMES=${LOOKBOTH_RENDER_MARKER_FRAMES:-3}
}

# The fuzz targets of the configured tree (fuzz_<name> -> <name>).
lookboth_fuzz_targets() {
  ninja -C "$LOOKBOTH_SANITIZE_BUILD_DIR" -t targets all |
    sed -n 's/^fuzz_\([A-Za-z0-9_]*\): .*/\1/p' | sort -u
}

# Runs one target for $2 seconds; returns 1 on a finding.
lookboth_fuzz_run() {
  local target=$1 seconds=$2
  shift 2
  local exe
  exe=$(find "$LOOKBOTH_SANITIZE_BUILD_DIR/libs" -name "fuzz_$target" -type f -perm -u+x | head -1)
  local seeds="$LOOKBOTH_SANITIZE_BUILD_DIR/libs/dataset/fuzz/lookboth-fuzz-seeds"
  local findings="${LOOKBOTH_FUZZ_FINDINGS:-$LOOKBOTH_SANITIZE_BUILD_DIR/fuzz-findings}/$target"
  mkdir -p "$findings"
  local work
  work=$(mktemp -d "${TMPDIR:-/tmp}/lookboth-fuzz-$target.XXXXXX")
  mkdir -p "$work/corpus" "$work/tmp"
  "$seeds" "$target" "$work/corpus"
  local log="$work/fuzz.log" status=0
  # Its own TMPDIR: the target's scratch files go when the run is over, crash or not.
  TMPDIR="$work/tmp" "$exe" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$findings/" "$@" "$work/corpus" >"$log" 2>&1 ||
    status=$?
  local runs
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  local coverage
  coverage=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | awk '{print $2}')
  local corpus
  corpus=$(find "$work/corpus" -type f | wc -l)
  if [[ $status -eq 0 ]]; then
    echo "fuzz $target: no finding in ${seconds} s (${runs:-?} inputs, coverage ${coverage:-?}, corpus $corpus)"
  else
    echo "fuzz $target: FINDING (libFuzzer exit $status) after ${runs:-?} inputs"
    local artifact saved
    artifact=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log" | tail -1)
    saved="${artifact:-$findings/$(date +%Y%m%d-%H%M%S)}.log"
    cp "$log" "$saved"
    if [[ -n $artifact ]]; then
      # Once more with the slow unwinder: a full stack through the
      # libraries built without frame pointers (OpenCV, MRPT...).
      TMPDIR="$work/tmp" ASAN_OPTIONS="$ASAN_OPTIONS:fast_unwind_on_malloc=0" \
        "$exe" -rss_limit_mb=2048 -timeout=10 "$artifact" >"$artifact.repro.log" 2>&1 || true
      echo "  input: $artifact"
      echo "  reproduce: $exe -rss_limit_mb=2048 -timeout=10 $artifact"
      grep -E '^(==[0-9]+== ?ERROR|SUMMARY|lookboth-fuzz:|    #1?[0-9] )' "$artifact.repro.log" |
        head -30 | sed 's/^/  /'
    else
      grep -E '^(==[0-9]+== ?ERROR|SUMMARY|lookboth-fuzz:|    #1?[0-9] )' "$log" |
        head -30 | sed 's/^/  /'
    fi
    echo "  fuzzing log: $saved"
  fi
  rm -rf "$work"
  [[ $status -eq 0 ]]
}

lookboth_fuzz_main() {
  if [[ $# -eq 1 && $1 == list ]]; then
    lookboth_sanitize_configure
    lookboth_fuzz_targets
    return 0
  fi
  if [[ $# -lt 2 || ! $2 =~ ^[0-9]+$ ]]; then
    echo "usage: scripts/fuzz.sh <target>[,<target>...]|all <seconds> [libFuzzer flags...]; scripts/fuzz.sh list" >&2
    return 2
  fi
  local which=$1 seconds=$2
  shift 2
  lookboth_sanitize_configure
  if ! lookboth_sanitize_fuzz_enabled; then
    echo "fuzz.sh: $LOOKBOTH_SANITIZE_BUILD_DIR has no fuzz targets (needs clang: apt install clang libclang-rt-14-dev)" >&2
    return 2
  fi
  local targets=()
  if [[ $which == all ]]; then
    mapfile -t targets < <(lookboth_fuzz_targets)
  else
    IFS=, read -r -a targets <<<"$which"
    local known
    known=$(lookboth_fuzz_targets)
    for target in "${targets[@]}"; do
      if ! grep -qx "$target" <<<"$known"; then
        echo "fuzz.sh: no fuzz target '$target' (have: $(tr '\n' ' ' <<<"$known"))" >&2
        return 2
      fi
    done
  fi
  cmake --build "$LOOKBOTH_SANITIZE_BUILD_DIR" --parallel "$LOOKBOTH_JOBS" \
    --target lookboth-fuzz-seeds "${targets[@]/#/fuzz_}"
  lookboth_sanitize_environment
  local failed=()
  for target in "${targets[@]}"; do
    lookboth_fuzz_run "$target" "$seconds" "$@" || failed+=("$target")
  done
  if [[ ${#failed[@]} -gt 0 ]]; then
    echo "fuzz.sh: findings in: ${failed[*]}"
    return 1
  fi
}

if [[ "${BASH_SOURCE[0]}" == "$0" ]]; then
  lookboth_fuzz_main "$@"
fi
