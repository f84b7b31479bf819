#!/usr/bin/env bash
# Conversion throughput and peak memory on synthetic streams of 1,000 and
# 10,000 frames (doc/benchmarks.md). Peer in the same run: `cp -r` of the
# same folder, the file-copy floor any conversion that keeps image bytes has.
#   scripts/bench_convert.sh [work_dir]
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
lookboth_build lookboth lookboth-bench-make-stream
LOOKBOTH="$LOOKBOTH_BUILD_DIR/apps/lookboth/lookboth"
MAKE="$LOOKBOTH_BUILD_DIR/libs/dataset/lookboth-bench-make-stream"
WORK=${1:-$(mktemp -d)}
mkdir -p "$WORK"
trap 'rm -rf "$WORK"/stream_*' EXIT

timed() {  # prints "seconds peak_kib" of a command
  /usr/bin/time -f "%e %M" -o "$WORK/time.txt" "$@" >/dev/null 2>"$WORK/err.txt" || { cat "$WORK/err.txt"; exit 1; }
  cat "$WORK/time.txt"
}

printf "%-8s %-24s %10s %12s %14s %12s\n" frames step seconds frames/s "peak RSS MiB" "vs cp -r"
for n in 1000 10000; do
  rm -rf "$WORK"/stream_*
  "$MAKE" "$n" "$WORK/stream_$n" >/dev/null
  read -r s_cp m_cp < <(timed cp -r "$WORK/stream_$n" "$WORK/stream_${n}_cp")
  read -r s_fr m_fr < <(timed "$LOOKBOTH" convert --from "$WORK/stream_$n" --to "$WORK/stream_$n.rawlog")
  read -r s_rf m_rf < <(timed "$LOOKBOTH" convert --from "$WORK/stream_$n.rawlog" --to "$WORK/stream_${n}_back")
  for row in "cp -r (peer):$s_cp:$m_cp" "folder -> rawlog:$s_fr:$m_fr" "rawlog -> folder:$s_rf:$m_rf"; do
    IFS=: read -r name s m <<<"$row"
    awk -v n="$n" -v name="$name" -v s="$s" -v m="$m" -v cp="$s_cp" 'BEGIN {
      fps = (s > 0) ? n / s : 0; printf "%-8d %-24s %10.2f %12.0f %14.1f %11.2fx\n", n, name, s, fps, m / 1024, s / (cp > 0 ? cp : 1) }'
  done
done
echo "machine: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), $(lscpu | awk -F: '/Model name/ {gsub(/^ +/, "", $2); print $2}')"
