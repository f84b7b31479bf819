#!/usr/bin/env bash
# Writes the ROS 2 bag fixtures of tests/data/ros2 with code independent of
# lookboth's reader: Foxglove's MCAP writer and ROS 2 CDR serializer from the
# npm registry (scripts/ros2_fixtures/write_mcap.mjs), Python's sqlite3 for
# the .db3 bag (scripts/ros2_fixtures/write_db3.py). Needs node/npm and
# python3 with yaml; the npm packages go into a temporary folder only.
# Usage: scripts/make_ros2_fixtures.sh [output folder, default tests/data/ros2]
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
out="$(realpath -m "${1:-$here/../tests/data/ros2}")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Versions pinned: the fixtures' bytes depend on them (tests/data/ros2/README.md).
packages=(
  @mcap/core@2.2.2
  @foxglove/rosmsg@5.0.5
  @foxglove/rosmsg2-serialization@3.1.0
  @foxglove/cdr@3.5.0
  lz4js@0.2.0
  @foxglove/wasm-zstd@1.0.1
  jpeg-js@0.4.4
)
(cd "$work" && npm init -y >/dev/null && npm install --no-audit --no-fund --silent "${packages[@]}")
# Node resolves an ES module's imports from the module's own folder.
cp "$here/ros2_fixtures/write_mcap.mjs" "$work/"
mkdir -p "$work/out"
node "$work/write_mcap.mjs" "$work/out"
python3 "$here/ros2_fixtures/write_db3.py" "$work/out"
rm "$work/out/db3_messages.json"

mkdir -p "$out"
rm -rf "$out/sample_db3" "$out/sample_mcap_folder"
cp -r "$work/out/." "$out/"
echo "make_ros2_fixtures.sh: wrote $(find "$work/out" -type f | wc -l) files to $out"
