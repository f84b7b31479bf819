#!/usr/bin/env bash
# Video input benchmark (doc/benchmarks.md): decode + marker detection of one
# ceiling camera's whole recording (1920x1080, 30 Hz, H.264, every frame of the
# drive, most without the robot) by `lookboth detect` on one core, against
# plain `ffmpeg -f null` decoding of the same file on one core (the peer: the
# cost of decoding alone) and against `lookboth detect` of the same frames as
# PNG files (what a camera folder held before). The recording is simulated
# (the `small` world, one camera, `store_radius_m: all`: the robot passes under
# it for 9 of the 36 s; the fisheye at 1 Hz, unused) and encoded with
# ffmpeg's libx264 (scripts/frames_to_video.py).
# Usage: scripts/bench_video.sh [crf, default 23]
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
lookboth="${LOOKBOTH:-$here/../build/apps/lookboth/lookboth}"
crf="${1:-23}"
reps=3
# LOOKBOTH_BENCH_DIR keeps the rendered recording (about 20 min on 2 cores) for a later run.
# shellcheck source=bench_common.sh
source "$here/bench_common.sh"
bench_work_dir
rm -f "$work"/t_*

sed -e 's/^name: small/name: video_bench/' \
    -e 's/calibration: ceiling_camera_640x360_ros.yaml/calibration: ceiling_camera_ros.yaml/' \
    -e 's/^  count: 6/  count: 1/' \
    -e 's/^  rate_hz: 10$/  rate_hz: 30/' \
    -e 's/^    rate_hz: 10$/    rate_hz: 1/' \
    -e 's/store_radius_m: 2.0/store_radius_m: all/' \
    -e 's/^noise:.*/noise: {marker_corner_sigma_px: 0.15, blob_sigma_px: 0.7}/' \
    "$here/../share/lookboth/scenarios/small.yaml" >"$work/scenario.yaml"
if [[ ! -d $work/site ]]; then
  "$lookboth" simulate --scenario "$work/scenario.yaml" --format folder --out "$work/site" >/dev/null
fi
rm -rf "$work/png" "$work/video"
"$lookboth" convert --from "$work/site" --to "$work/png" --cameras cam00 >/dev/null
"$lookboth" convert --from "$work/site" --to "$work/video" --cameras cam00 >/dev/null
python3 "$here/frames_to_video.py" "$work/video/cameras/cam00" --crf "$crf"
frames=$(($(wc -l <"$work/png/cameras/cam00/frames.csv") - 1))
seconds=$(awk -v n="$frames" 'BEGIN { printf "%.1f", n / 30 }')
mb=$(du -m "$work/video/cameras/cam00/video.mp4" | cut -f1)
png_mb=$(du -sm "$work/png/cameras/cam00/frames" | cut -f1)

wait_for_quiet_machine

run() {  # run NAME CMD...: wall ms of CMD, pinned to one core
  local name=$1; shift
  local t0 t1
  t0=$(date +%s%N)
  taskset -c 0 "$@" >/dev/null 2>"$work/stderr.txt" || { cat "$work/stderr.txt" >&2; exit 1; }
  t1=$(date +%s%N)
  echo $(( (t1 - t0) / 1000000 )) >>"$work/t_$name"
}
median() { sort -n | sed -n "$(( (reps + 1) / 2 ))p"; }
for ((r = 0; r < reps; r++)); do
  run ffmpeg ffmpeg -v error -threads 1 -i "$work/video/cameras/cam00/video.mp4" -f null -
  rm -rf "$work/out_video" "$work/out_png"
  run video "$lookboth" detect "$work/video" --threads 1 --no-blobs --detections-only \
    --out "$work/out_video"
  run png "$lookboth" detect "$work/png" --threads 1 --no-blobs --detections-only \
    --out "$work/out_png"
done
markers() { tail -n +2 "$1/detections/markers.csv" 2>/dev/null | grep -c . || true; }
echo "one camera: $frames frames = $seconds s at 30 Hz, 1920x1080; H.264 (libx264 crf $crf) $mb MB, PNG $png_mb MB"
printf '%-34s %8s %10s %12s\n' run "wall s" "frames/s" "x real time"
for name in ffmpeg video png; do
  case $name in
    ffmpeg) label="ffmpeg -threads 1 -f null (decode)" ;;
    video) label="lookboth detect, video" ;;
    png) label="lookboth detect, PNG files" ;;
  esac
  ms=$(median <"$work/t_$name")
  awk -v l="$label" -v ms="$ms" -v f="$frames" -v s="$seconds" \
    'BEGIN { printf "%-34s %8.2f %10.1f %12.2f\n", l, ms / 1000, f / (ms / 1000), s / (ms / 1000) }'
done
v=$(median <"$work/t_video"); f=$(median <"$work/t_ffmpeg")
awk -v v="$v" -v f="$f" 'BEGIN { printf "detect on video / ffmpeg decode alone: %.2fx the time\n", v / f }'
echo "markers found: video $(markers "$work/out_video"), PNG $(markers "$work/out_png")"
