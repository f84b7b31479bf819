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

RUNS=${RUNS:-3}

timed() {  # prints "seconds peak_kib" of a command
  /usr/bin/time -f "%e %M" -o "$WORK/time.txt" "$@" >/dev/null 2>"$WORK/err.txt" || { cat "$WORK/err.txt"; exit 1; }
  cat "$WORK/time.txt"
}

# Runs a step RUNS times (removing its output before each run); prints
# "median_s min_s max_s max_peak_kib".
repeat() {
  local output=$1; shift
  local times=() peak=0
  for ((r = 0; r < RUNS; r++)); do
    rm -rf "$output" "${output%.rawlog}.yaml" "${output%.rawlog}_Images"
    sync
    read -r s m < <(timed "$@")
    times+=("$s")
    (( m > peak )) && peak=$m
  done
  printf "%s\n" "${times[@]}" | sort -g | awk -v peak="$peak" '{ t[NR] = $1 } END {
    printf "%s %s %s %d\n", t[int((NR + 1) / 2)], t[1], t[NR], peak }'
}

printf "%-8s %-20s %9s %17s %10s %14s %10s\n" frames step "median s" "range s" frames/s "peak RSS MiB" "vs cp -r"
for n in 1000 10000; do
  rm -rf "$WORK"/stream_*
  "$MAKE" "$n" "$WORK/stream_$n" >/dev/null
  read -r s_cp lo_cp hi_cp m_cp < <(repeat "$WORK/stream_${n}_cp" cp -r "$WORK/stream_$n" "$WORK/stream_${n}_cp")
  read -r s_fr lo_fr hi_fr m_fr < <(repeat "$WORK/stream_$n.rawlog" "$LOOKBOTH" convert --from "$WORK/stream_$n" --to "$WORK/stream_$n.rawlog")
  read -r s_rf lo_rf hi_rf m_rf < <(repeat "$WORK/stream_${n}_back" "$LOOKBOTH" convert --from "$WORK/stream_$n.rawlog" --to "$WORK/stream_${n}_back")
  for row in "cp -r (peer):$s_cp:$lo_cp:$hi_cp:$m_cp" "folder -> rawlog:$s_fr:$lo_fr:$hi_fr:$m_fr" "rawlog -> folder:$s_rf:$lo_rf:$hi_rf:$m_rf"; do
    IFS=: read -r name s lo hi m <<<"$row"
    awk -v n="$n" -v name="$name" -v s="$s" -v lo="$lo" -v hi="$hi" -v m="$m" -v cp="$s_cp" 'BEGIN {
      fps = (s > 0) ? n / s : 0;
      printf "%-8d %-20s %9.2f %8.2f - %6.2f %10.0f %14.1f %9.2fx\n", n, name, s, lo, hi, fps, m / 1024, s / (cp > 0 ? cp : 1) }'
  done
done
echo "runs per step: $RUNS; frames: 160x120 PNG, plus 1 marker, 1 blob observation and 2 poses per frame"
echo "machine: $(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), $(lscpu | awk -F: '/Model name/ {gsub(/^ +/, "", $2); print $2}')"
