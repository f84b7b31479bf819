#!/usr/bin/env bash
# Full-recording benchmark (doc/benchmarks.md, "Full recordings"): every
# frame of a drive, as fixed cameras record it, most frames without the
# robot. `small`'s world, its first 10 s: 6 ceiling cameras at 1920x1080,
# 30 Hz (`store_radius_m: all`: 1782 frames), the fisheye at 640x360, 10 Hz.
# In one run, on the same frames:
#   - marker detection on one core (taskset, --threads 1, --no-blobs):
#     examining every frame (coarse_period_s: 0) against the coarse search
#     (the default), from PNG files and from H.264 videos (libx264, crf 23,
#     a key frame a second: the coarse frames are the key frames; and
#     without that, coarse_key_frames_max_s: 0), and the coarse search with
#     every coarse frame searched, exactly (coarse_change_grey: 0, no
#     SceneChange; coarse_key_frame_previews: false);
#     recall of the coarse search against every frame, per format;
#   - the decoding peers: `ffmpeg -threads 1 -f null` of the same PNG files
#     and videos (decoding alone, the floor of anything that reads every frame);
#   - the whole `register` on 2 cores (detection, odometry, the stages),
#     overlapped (the default) and --sequential from the PNG files, and
#     from the videos, against the drive's span;
#   - the floor of that `register` from the videos on 2 cores: the work it
#     cannot leave out (the cameras the robot passes, the odometry, the blob
#     search), each part alone on one core, shared perfectly over two.
# Usage: LOOKBOTH_BENCH_DIR=/tmp/fr scripts/bench_full_recording.sh  (keeps the
# rendered recording, about 15 min on 2 cores, for the next run); REPS=3.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
lookboth="${LOOKBOTH:-$here/../build/apps/lookboth/lookboth}"
reps="${REPS:-3}"
# shellcheck source=bench_common.sh
source "$here/bench_common.sh"
bench_work_dir
rm -f "$work"/t_*

sed -e 's/^name: small/name: full_recording/' \
    -e 's/calibration: ceiling_camera_640x360_ros.yaml/calibration: ceiling_camera_ros.yaml/' \
    -e 's/^  rate_hz: 10$/  rate_hz: 30/' \
    -e 's/store_radius_m: 2.0/store_radius_m: all/' \
    -e 's/^noise:.*/noise: {marker_corner_sigma_px: 0.15, blob_sigma_px: 1.2}/' \
    "$here/../share/lookboth/scenarios/small.yaml" >"$work/scenario.yaml"
if [[ ! -d $work/site ]]; then
  "$lookboth" simulate --scenario "$work/scenario.yaml" --duration 10 --format folder \
    --out "$work/site" >/dev/null
fi
cameras=(cam00 cam01 cam02 cam03 cam04 cam05)
# The videos' folder is named by their quality: one kept from another run at
# another quality is not taken for them.
crf=23
video="$work/video_crf$crf"
if [[ ! -d $video ]]; then
  "$lookboth" convert --from "$work/site" --to "${video}_tmp" >/dev/null
  # A key frame a second, as network cameras are usually set up; crf 23 (the
  # simulator's own videos' quality) gives about 3.1 Mbit/s here, near the 4
  # Mbit/s a camera vendor's guide recommends for H.264 at 1080p30
  # (doc/benchmarks.md, "Full recordings").
  for c in "${cameras[@]}"; do
    python3 "$here/frames_to_video.py" "${video}_tmp/cameras/$c" --keyint 30 --crf "$crf"
  done
  mv "${video}_tmp" "$video"
fi
printf 'detect:\n  markers:\n    coarse_period_s: 0\n' >"$work/every.yaml"
printf 'detect:\n  markers:\n    coarse_period_s: 0.2\n' >"$work/coarse.yaml"
printf 'detect:\n  markers:\n    coarse_key_frames_max_s: 0\n' >"$work/no_keys.yaml"
printf 'detect:\n  markers:\n    coarse_change_grey: 0\n    coarse_key_frame_previews: false\n' \
  >"$work/searched.yaml"

wait_for_quiet_machine

run() { timed_run "$@"; }
detect() {  # detect NAME DATASET CONFIG
  rm -rf "$work/det_$1"
  run "$1" taskset -c 0 "$lookboth" detect "$2" --threads 1 --no-blobs --detections-only \
    --config "$work/$3.yaml" --out "$work/det_$1"
}
png_dirs=() video_files=()
for c in "${cameras[@]}"; do
  png_dirs+=("$work/site/cameras/$c/frames")
  video_files+=("$video/cameras/$c/video.mp4")
done
ffmpeg_each='for input in "$@"; do
  case $input in
    *.mp4) ffmpeg -v error -threads 1 -i "$input" -f null - ;;
    *) ffmpeg -v error -threads 1 -pattern_type glob -i "$input/*.png" -f null - ;;
  esac
done'
# passed_cameras SEPARATOR: the cameras in which examining every frame of
# the videos found the marker.
passed_cameras() {
  tail -n +2 "$work/det_video_every/detections/markers.csv" | cut -d, -f2 | sort -u | paste -sd"$1" -
}
# A floor of `register` from the videos, each part alone on one core: its
# work on the cameras the robot passes (every frame of their passes decoded
# and searched, and their coarse frames), the fisheye's odometry and its blob
# search; less the fisheye's decoding (once in register, twice here:
# `ffmpeg`'s figure, with its own start-up, so the floor errs low) and the
# program's start-up (`lookboth --version`) but one.
register_floor_runs() {
  local passed
  passed=$(passed_cameras ,)
  [[ -n $passed ]] || { echo "no camera saw the marker: no floor" >&2; return 0; }
  rm -rf "$work/det_floor_passes" "$work/det_floor_blobs"
  run floor_passes taskset -c 0 "$lookboth" detect "$video" --cameras "$passed" --threads 1 \
    --no-blobs --detections-only --out "$work/det_floor_passes"
  run floor_odometry taskset -c 0 "$lookboth" odometry "$video" --dry-run
  run floor_blobs taskset -c 0 "$lookboth" detect "$video" --cameras fisheye --no-markers \
    --threads 1 --detections-only --out "$work/det_floor_blobs"
  run floor_fisheye_decoding taskset -c 0 bash -c "$ffmpeg_each" _ "$video/fisheye/frames"
  run start_up "$lookboth" --version
}

for ((r = 0; r < reps; r++)); do
  run ffmpeg_png taskset -c 0 bash -c "$ffmpeg_each" _ "${png_dirs[@]}"
  run ffmpeg_video taskset -c 0 bash -c "$ffmpeg_each" _ "${video_files[@]}"
  # One camera the robot never passes (cam00): the cost of an empty frame.
  run ffmpeg_png_empty taskset -c 0 bash -c "$ffmpeg_each" _ "${png_dirs[0]}"
  run ffmpeg_video_empty taskset -c 0 bash -c "$ffmpeg_each" _ "${video_files[0]}"
  rm -rf "$work/det_png_empty" "$work/det_video_empty"
  run png_empty taskset -c 0 "$lookboth" detect "$work/site" --cameras cam00 --threads 1 \
    --detections-only --config "$work/every.yaml" --out "$work/det_png_empty"
  run video_empty taskset -c 0 "$lookboth" detect "$video" --cameras cam00 --threads 1 \
    --detections-only --config "$work/every.yaml" --out "$work/det_video_empty"
  detect png_every "$work/site" every
  detect png_coarse "$work/site" coarse
  detect video_every "$video" every
  detect video_coarse "$video" coarse
  detect video_no_keys "$video" no_keys
  detect png_searched "$work/site" searched
  detect video_searched "$video" searched
  run register_overlapped "$lookboth" register "$work/site" --no-write-back --overwrite \
    --out "$work/reg_overlapped"
  run register_sequential "$lookboth" register "$work/site" --no-write-back --overwrite \
    --out "$work/reg_sequential" --sequential
  run register_video "$lookboth" register "$video" --no-write-back --overwrite \
    --out "$work/reg_video"
  register_floor_runs
done

median() { sort -n | sed -n "$(( (reps + 1) / 2 ))p"; }
frames=0
for c in "${cameras[@]}"; do
  frames=$((frames + $(tail -n +2 "$work/site/cameras/$c/frames.csv" | grep -c .)))
done
echo "full recording: 6 cameras, $frames frames at 1920x1080 (10 s at 30 Hz); medians of $reps"
printf '%-44s %8s %10s %10s\n' run "wall s" "ms/frame" "markers"
for name in ffmpeg_png png_every png_coarse png_searched ffmpeg_video video_every video_coarse \
  video_searched video_no_keys; do
  ms=$(median <"$work/t_$name")
  markers=-
  [[ -f $work/det_$name/detections/markers.csv ]] &&
    markers=$(($(tail -n +2 "$work/det_$name/detections/markers.csv" | grep -c .)))
  awk -v l="$name" -v ms="$ms" -v f="$frames" -v m="$markers" \
    'BEGIN { printf "%-44s %8.2f %10.2f %10s\n", l, ms / 1000, ms / f, m }'
done
empty=$(tail -n +2 "$work/site/cameras/cam00/frames.csv" | grep -c .)
echo "an empty frame (cam00, $empty frames, every frame examined), ms per frame:"
for name in ffmpeg_png_empty png_empty ffmpeg_video_empty video_empty; do
  ms=$(median <"$work/t_$name")
  awk -v l="$name" -v ms="$ms" -v f="$empty" 'BEGIN { printf "  %-40s %8.2f\n", l, ms / f }'
done
for name in register_overlapped register_sequential register_video; do
  ms=$(median <"$work/t_$name")
  awk -v l="$name (2 cores)" -v ms="$ms" \
    'BEGIN { printf "%-44s %8.2f   %.2fx the drive (10 s)\n", l, ms / 1000, ms / 10000 }'
  grep "run time" "$work/out_$name.txt" || true
done
if [[ -f $work/t_floor_passes ]]; then
  echo "register's floor on 2 cores (from the videos; each part alone on one core, ms):"
  for name in floor_passes floor_odometry floor_blobs floor_fisheye_decoding start_up; do
    printf '  %-42s %8s\n' "$name" "$(median <"$work/t_$name")"
  done
  echo "  (floor_passes: $(passed_cameras ' '))"
  awk -v p="$(median <"$work/t_floor_passes")" -v o="$(median <"$work/t_floor_odometry")" \
    -v b="$(median <"$work/t_floor_blobs")" -v f="$(median <"$work/t_floor_fisheye_decoding")" \
    -v s="$(median <"$work/t_start_up")" 'BEGIN {
      w = (p + o + b - f - 3 * s) / 2 + s
      printf "  (passes + odometry + blobs - fisheye decoding - 3 start-ups) / 2 + 1 start-up: %.2f s, %.2fx the drive (10 s)\n", w / 1000, w / 10000 }'
fi
# Recall of the coarse search against every frame, per format.
for format in png_coarse png_searched video_coarse video_searched video_no_keys; do
  python3 "$here/coarse_recall.py" "$work/det_${format%%_*}_every" "$work/det_$format" "$format"
done
grep "examined" "$work/out_png_coarse.txt" "$work/out_video_coarse.txt" \
  "$work/out_png_searched.txt" "$work/out_video_searched.txt" || true
