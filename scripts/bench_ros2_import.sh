#!/usr/bin/env bash
# ROS 2 bag import benchmark (doc/benchmarks.md): `lookboth convert` of one
# synthetic recording stored as MCAP (zstd chunks, uncompressed chunks) and as
# sqlite3 .db3, against `cp` of the same bag on the same filesystem (the peer:
# the cost of just reading and writing those bytes). Two lengths, the long one
# 4x the short one, so that peak memory can be checked to be flat in length.
# The bags are written with the fixtures' independent npm writer
# (scripts/ros2_fixtures/write_bench.mjs, write_bench_db3.py); the npm packages
# go into the temporary folder only. Needs node/npm, python3, /usr/bin/time.
# Usage: scripts/bench_ros2_import.sh [seconds of the short recording, default 20]
#   (about 14 MB of bag per second: 20 -> ~0.28 GB and 80 -> ~1.1 GB)
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
lookboth="${LOOKBOTH:-$here/../build/apps/lookboth/lookboth}"
short="${1:-20}"
reps=3
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Same pinned versions as make_ros2_fixtures.sh.
(cd "$work" && npm init -y >/dev/null && npm install --no-audit --no-fund --silent \
  @mcap/core@2.2.2 @foxglove/rosmsg@5.0.5 @foxglove/rosmsg2-serialization@3.1.0 \
  @foxglove/cdr@3.5.0 @foxglove/wasm-zstd@1.0.1 jpeg-js@0.4.4)
cp "$here/ros2_fixtures/write_bench.mjs" "$here/ros2_fixtures/ros2_schemas.mjs" "$work/"  # Node resolves imports from the module's folder
mkdir -p "$work/bags"
for len in short long; do
  secs=$([ $len = short ] && echo "$short" || echo $((4 * short)))
  node "$work/write_bench.mjs" "$work/bags" "$len" "$secs"
  python3 "$here/ros2_fixtures/write_bench_db3.py" "$work/bags/$len.msgs" "$work/bags/$len.db3"
  rm "$work/bags/$len.msgs"
done

# shellcheck source=bench_common.sh
source "$here/bench_common.sh"
wait_for_quiet_machine

# run NAME CMD...: wall ms (ns clock) and peak RSS (KB, /usr/bin/time -v) of CMD.
run() {
  local name=$1; shift
  sync  # no dirty pages of the previous run left to throttle this one
  local t0 t1
  t0=$(date +%s%N)
  /usr/bin/time -v -o "$work/time.txt" "$@" >/dev/null 2>"$work/stderr.txt" ||
    { cat "$work/stderr.txt" >&2; exit 1; }
  t1=$(date +%s%N)
  echo "$(( (t1 - t0) / 1000000 )) $(awk '/Maximum resident/ { print $NF }' "$work/time.txt")" >>"$work/$name"
}
median() { sort -n | sed -n "$(( (reps + 1) / 2 ))p"; }

topics=(--topic /fisheye/image/compressed=fisheye:fisheye --topic /cam/image_raw=cam01:env_camera
        --topic /odom=odometry:odometry --marker DICT_4X4_50:0:0.2)
printf '%-12s %-6s %9s %7s %9s %7s %9s\n' storage length "bag MB" "cp s" "import s" ratio "RSS MB"
for len in short long; do
  for suffix in _zstd.mcap _plain.mcap .db3; do
    bag="$work/bags/$len$suffix"
    id="$len$suffix"
    for ((r = 0; r < reps; r++)); do  # cp and import alternately: same cache and load state
      run "$id.cp" cp "$bag" "$work/copy"
      rm -f "$work/copy"
      mkdir -p "$work/out"
      run "$id.import" "$lookboth" convert --from "$bag" --to "$work/out/o.rawlog" --overwrite "${topics[@]}"
      rm -rf "$work/out"
    done
    cp_ms=$(cut -d' ' -f1 "$work/$id.cp" | median)
    im_ms=$(cut -d' ' -f1 "$work/$id.import" | median)
    rss_kb=$(cut -d' ' -f2 "$work/$id.import" | median)
    awk -v s="$suffix" -v l=$len -v b="$(stat -c %s "$bag")" -v c="$cp_ms" -v i="$im_ms" -v m="$rss_kb" \
      'BEGIN { printf "%-12s %-6s %9.0f %7.2f %9.2f %7.1f %9.0f\n", (s == ".db3" ? "sqlite3" : s == "_zstd.mcap" ? "mcap-zstd" : "mcap-plain"), l, b / 1e6, c / 1e3, i / 1e3, i / c, m / 1024 }'
  done
done
echo "load average (1 min) after: $(load); medians of $reps runs; wall time from date +%s%N, RSS from /usr/bin/time -v"
