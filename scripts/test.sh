#!/usr/bin/env bash
# Sets up, builds (Release, warnings as errors) and runs every test with ctest.
# Exits non-zero when anything fails. Extra arguments go to ctest (e.g. -R geometry).
#
#   scripts/test.sh --sanitize [ctest args...]
#     The unit tests built with AddressSanitizer and UBSan in build-sanitize,
#     the tree that scripts/fuzz.sh uses too (doc/reliability.md, "Fuzzing
#     and sanitizers"): all of them, or those $LOOKBOTH_SANITIZE_TESTS (a
#     ctest -R regex) selects, as CI does (.ci/run: the file readers'). The
#     rendering, odometry and adjustment tests take minutes each under the
#     sanitizers; the end-to-end tests are left out.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

if [[ ${1:-} == --sanitize ]]; then
  shift
  source "$LOOKBOTH_ROOT/scripts/fuzz.sh"
  tests=${LOOKBOTH_SANITIZE_TESTS:-.}
  lookboth_sanitize_configure
  # Only what those tests run: their build-tree executables, read from
  # ctest's files (ctest lists no command for an executable not built yet).
  mapfile -t targets < <(python3 - "$LOOKBOTH_SANITIZE_BUILD_DIR" "$tests" <<'PY'
import os, re, subprocess, sys
build, selected = os.path.realpath(sys.argv[1]), re.compile(sys.argv[2])
commands, labels = {}, {}
for root, _, files in os.walk(build):
    if "CTestTestfile.cmake" not in files:
        continue
    for line in open(os.path.join(root, "CTestTestfile.cmake")):
        m = re.match(r"add_test\(\[=\[(.*?)\]=\] (.*)\)$", line)
        if m:
            commands[m[1]] = re.findall(r'"([^"]*)"', m[2])
        m = re.match(r'set_tests_properties\(\[=\[(.*?)\]=\] PROPERTIES .*?LABELS "([^"]*)"', line)
        if m:
            labels[m[1]] = m[2].split(";")
# Executables are arguments, or values of -DNAME=path arguments of cmake -P scripts.
names = {os.path.basename(path) for test, args in commands.items()
         if "unit" in labels.get(test, []) and selected.search(test)
         for path in (arg.split("=", 1)[-1] for arg in args) if path.startswith(build + "/")}
if os.path.exists(os.path.join(build, "build.ninja")):
    listing = subprocess.run(["ninja", "-C", build, "-t", "targets", "all"], check=True,
                             capture_output=True, text=True).stdout
    names &= {line.split(":")[0] for line in listing.splitlines()}
print("\n".join(sorted(names)))
PY
  )
  cmake --build "$LOOKBOTH_SANITIZE_BUILD_DIR" --parallel "$LOOKBOTH_JOBS" --target "${targets[@]}"
  lookboth_sanitize_environment
  cd "$LOOKBOTH_SANITIZE_BUILD_DIR"
  ctest --output-on-failure --parallel "$LOOKBOTH_JOBS" -L unit -R "$tests" "$@"
  exit
fi

lookboth_build
cd "$LOOKBOTH_BUILD_DIR"
ctest --output-on-failure --parallel "$LOOKBOTH_JOBS" "$@"
