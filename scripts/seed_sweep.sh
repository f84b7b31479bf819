#!/usr/bin/env bash
# Runs the statistical unit tests on other noise realisations: each test
# adds random noise, solves and checks a bound (NEES / dof, measured against
# predicted RMSE, an error bound) on the draws of its seeds. With
# LOOKBOTH_TEST_SEED_OFFSET=k (lookboth/core/test_seed.h) every such seed is
# shifted by k, so a run per offset shows whether a bound holds over the
# statistic's spread or only on the one realisation the test was written on
# (doc/reliability.md, "Bounds over several seeds").
#
#   scripts/seed_sweep.sh <build dir> <first offset> <last offset> [ctest -R regex]
#
# The build dir holds the tests, built (e.g. ninja -C <build dir> test_calib_joint).
# The default regex selects the statistical tests. Prints a line per test and
# offset as it ends, then a table (test x offset); each run's output is kept in
# $LOOKBOTH_SEED_SWEEP_LOGS (default <build dir>/seed_sweep/<offset>/<test>.log).
# Exits 1 when any run failed, 2 on a usage error.
set -euo pipefail

readonly DEFAULT_TESTS='^(vo/bearing_geometry|calib/stages|calib/joint|calib/joint_costs|pipeline/pipeline|detect/marker_detector|detect/detect_dataset|sim/marker_corners|registration/site_frame|registration/facility_check)$'

usage() {
  echo "usage: $0 <build dir> <first offset> <last offset> [ctest -R regex]" >&2
  exit 2
}

[[ $# -ge 3 && $# -le 4 ]] || usage
build=$1
first=$2
last=$3
regex=${4:-$DEFAULT_TESTS}
[[ $first =~ ^[0-9]+$ && $last =~ ^[0-9]+$ && $first -le $last ]] || usage
[[ -f $build/CTestTestfile.cmake ]] || {
  echo "$build: not a build directory with tests (no CTestTestfile.cmake)" >&2
  exit 2
}
logs=${LOOKBOTH_SEED_SWEEP_LOGS:-"$build/seed_sweep"}

# The tests the regex selects, one name a line.
mapfile -t tests < <(ctest --test-dir "$build" -N -R "$regex" |
  sed -n 's/^ *Test *#[0-9]*: *\(.*\)$/\1/p')
[[ ${#tests[@]} -gt 0 ]] || {
  echo "no test in $build matches '$regex'" >&2
  exit 2
}

declare -A outcome
failures=0

# Runs test $1 under offset $2; records PASS or FAIL and prints a line.
run_one() {
  local test=$1 offset=$2 log
  log="$logs/$offset/${test//\//_}.log"
  mkdir -p "$(dirname "$log")"
  local start=$SECONDS status=PASS
  if ! LOOKBOTH_TEST_SEED_OFFSET=$offset ctest --test-dir "$build" -R "^${test}\$" -V \
    >"$log" 2>&1; then
    status=FAIL
    failures=$((failures + 1))
  fi
  outcome["$test,$offset"]=$status
  local failed
  failed=$(sed -n 's/^.*\[  FAILED  \] \([A-Za-z0-9_/]*\.[A-Za-z0-9_/]*\).*$/\1/p' "$log" |
    sort -u | tr '\n' ' ')
  printf 'offset %-3s %-30s %s %4d s %s\n' "$offset" "$test" "$status" \
    $((SECONDS - start)) "${failed:+($failed)}"
}

# The table: a row per test, a column per offset, its failures counted.
summary() {
  printf '\n%-30s' "test \\ offset"
  for ((o = first; o <= last; ++o)); do printf ' %3s' "$o"; done
  printf '  failed\n'
  for test in "${tests[@]}"; do
    printf '%-30s' "$test"
    local failed=0
    for ((o = first; o <= last; ++o)); do
      if [[ ${outcome["$test,$o"]} == PASS ]]; then
        printf ' %3s' .
      else
        printf ' %3s' F
        failed=$((failed + 1))
      fi
    done
    printf '  %d/%d\n' "$failed" $((last - first + 1))
  done
  echo "(. passed, F failed; logs in $logs/<offset>/)"
}

for ((offset = first; offset <= last; ++offset)); do
  for test in "${tests[@]}"; do run_one "$test" "$offset"; done
done
summary
if ((failures > 0)); then
  echo "$failures run(s) failed"
  exit 1
fi
echo "every run passed"
