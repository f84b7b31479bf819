#!/usr/bin/env bash
# Sets up, builds (Release, warnings as errors) and runs every test with ctest.
# Exits non-zero when anything fails. Extra arguments go to ctest (e.g. -R geometry).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

lookboth_build
cd "$LOOKBOTH_BUILD_DIR"
ctest --output-on-failure --parallel "$LOOKBOTH_JOBS" "$@"
