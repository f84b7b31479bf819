#!/usr/bin/env bash
# Full-recording benchmark at the paper's scale (doc/benchmarks.md, "Full
# recordings: 43 cameras"): the `paper` facility's first 60 s as its cameras
# record it: 43 cameras at 1920x1080 and 30 Hz, every frame of the drive
# (`store_radius_m: all`), each camera one H.264 video written by the
# simulator (`cameras.video`: libx264 crf 23, a key frame a second); the
# fisheye at 1920x1080, 30 Hz, PNG. In one run, on the same files:
#   - the whole `lookboth register` on 2 cores (detection with the coarse
#     search beside the fisheye's odometry, then the stages), against the
#     drive's 60 s;
#   - `lookboth detect` of the 43 cameras alone, 2 threads, coarse search
#     (the default) and every frame examined (coarse_period_s: 0): time and
#     the markers each finds (the coarse search's recall against every frame);
#   - the peer: `ffmpeg -threads 1 -f null` decoding every frame of the 43
#     videos, two at a time (2 cores), the floor of anything reading every frame;
#   - the cost of the key frames of five cameras the robot does not pass
#     (decoded as previews, compared, searched when the view changed; and
#     every one searched exactly) beside ffmpeg decoding the same key frames
#     (with and without the loop filter);
#   - `register` (fisheye JPEG) and `detect` with every coarse frame
#     searched, exactly (coarse_change_grey: 0, no SceneChange;
#     coarse_key_frame_previews: false): the peers of the default's skipping
#     of unchanged views and its key-frame previews;
#   - the registration's accuracy (`lookboth evaluate`);
#   - the same `register` with the fisheye's frames as JPEG (a copy of the
#     site, its PNG frames re-encoded by `ffmpeg -q:v 3`, the cameras' videos
#     hard-linked): a robot's camera records JPEG or video, and a 1920x1080
#     PNG takes 3-4 times as long to decode as a JPEG.
# Usage: LOOKBOTH_BENCH_DIR=/tmp/fr43 scripts/bench_full_recording_paper.sh
# (keeps the simulated recording for the next run: about 40 min on 2 cores,
# 7 GB of memory, 2.5 GB on disk).
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
lookboth="${LOOKBOTH:-$here/../build/apps/lookboth/lookboth}"
# shellcheck source=bench_common.sh
source "$here/bench_common.sh"
bench_work_dir
rm -f "$work"/t_*
drive_s=60

sed -e 's/^name: paper/name: paper_full_recording/' \
    -e 's/^  store_radius_m: 2.5$/  store_radius_m: all\n  video: {crf: 23, key_frame_interval_s: 1}/' \
    "$here/../share/lookboth/scenarios/paper.yaml" >"$work/scenario.yaml"
grep -q "video:" "$work/scenario.yaml" || { echo "paper.yaml changed: no store_radius_m: 2.5" >&2; exit 1; }
if [[ ! -d $work/site ]]; then
  "$lookboth" simulate --scenario "$work/scenario.yaml" --duration "$drive_s" --format folder \
    --threads 2 --out "$work/site" >"$work/simulate.txt"
fi
printf 'detect:\n  markers:\n    coarse_period_s: 0\n' >"$work/every.yaml"
printf 'detect:\n  markers:\n    coarse_change_grey: 0\n    coarse_key_frame_previews: false\n' \
  >"$work/searched.yaml"
mapfile -t videos < <(ls "$work"/site/cameras/*/video.mp4)

# The fisheye as JPEG: made once beside the site (again when the site is
# newer), every other file hard-linked (register only reads them).
jpeg=$work/site_jpeg
if [[ ! -f $jpeg/fisheye/frames.csv || $work/site/fisheye/frames.csv -nt $jpeg/fisheye/frames.csv ]]
then
  rm -rf "$jpeg"
  cp -al "$work/site" "$jpeg"
  rm -rf "$jpeg/fisheye/frames" "$jpeg/fisheye/frames.csv"
  mkdir -p "$jpeg/fisheye/frames"
  (cd "$work/site/fisheye/frames" && ls | sed -n 's/\.png$//p' |
    xargs -P 2 -I{} ffmpeg -v error -i {}.png -q:v 3 "$jpeg/fisheye/frames/{}.jpg")
  sed 's/\.png$/.jpg/' "$work/site/fisheye/frames.csv" >"$jpeg/fisheye/frames.csv"
fi

wait_for_quiet_machine

run() { timed_run "$@"; }
rm -rf "$work"/reg_* "$work"/det_*
run register "$lookboth" register "$work/site" --no-write-back --overwrite --out "$work/reg_coarse"
run register_jpeg "$lookboth" register "$work/site_jpeg" --no-write-back --overwrite \
  --out "$work/reg_jpeg"
run detect_coarse "$lookboth" detect "$work/site" --threads 2 --no-blobs --detections-only \
  --out "$work/det_coarse"
run register_jpeg_searched "$lookboth" register "$work/site_jpeg" --no-write-back --overwrite \
  --config "$work/searched.yaml" --out "$work/reg_jpeg_searched"
run detect_searched "$lookboth" detect "$work/site" --threads 2 --no-blobs --detections-only \
  --config "$work/searched.yaml" --out "$work/det_searched"
run ffmpeg_videos bash -c 'printf "%s\n" "$@" |
  xargs -P 2 -I{} ffmpeg -v error -threads 1 -i {} -f null -' _ "${videos[@]}"
run detect_every "$lookboth" detect "$work/site" --threads 2 --no-blobs --detections-only \
  --config "$work/every.yaml" --out "$work/det_every"
# Key frames alone: five cameras the robot does not pass in these 60 s, one
# core; the peer decodes their key frames only (ffmpeg -skip_frame nokey).
empty=(cam01 cam02 cam03 cam04 cam05)
key_videos=()
for c in "${empty[@]}"; do key_videos+=("$work/site/cameras/$c/video.mp4"); done
run keys_detect taskset -c 0 "$lookboth" detect "$work/site" --cameras "$(IFS=,; echo "${empty[*]}")" \
  --threads 1 --no-blobs --detections-only --out "$work/det_keys"
run keys_detect_searched taskset -c 0 "$lookboth" detect "$work/site" \
  --cameras "$(IFS=,; echo "${empty[*]}")" --threads 1 --no-blobs --detections-only \
  --config "$work/searched.yaml" --out "$work/det_keys_searched"
run keys_ffmpeg taskset -c 0 bash -c 'for v in "$@"; do
  ffmpeg -v error -threads 1 -skip_frame nokey -i "$v" -f null -; done' _ "${key_videos[@]}"
run keys_ffmpeg_unfiltered taskset -c 0 bash -c 'for v in "$@"; do
  ffmpeg -v error -threads 1 -skip_loop_filter all -skip_frame nokey -i "$v" -f null -; done' \
  _ "${key_videos[@]}"

frames=0
for v in "$work"/site/cameras/*/video.csv; do frames=$((frames + $(tail -n +2 "$v" | grep -c .))); done
echo "full recording: ${#videos[@]} cameras, $frames frames at 1920x1080 (${drive_s} s at 30 Hz), H.264"
printf '%-36s %8s %10s %12s\n' run "wall s" "x drive" "ms/frame"
for name in register register_jpeg register_jpeg_searched detect_coarse detect_searched \
  ffmpeg_videos detect_every; do
  ms=$(cat "$work/t_$name")
  awk -v l="$name" -v ms="$ms" -v f="$frames" -v d="$drive_s" \
    'BEGIN { printf "%-36s %8.1f %10.2f %12.2f\n", l, ms / 1000, ms / 1000 / d, ms / f }'
done
# detect examines each camera's key frames and its last frame (decoded after
# the frames since the last key frame); the whole command, start-up included.
examined=$(grep -o "([0-9]* examined" "$work/out_keys_detect.txt" | grep -o "[0-9]*" | paste -sd+ | bc)
echo "keys_detect: $(cat "$work/t_keys_detect") ms for the $examined frames examined, one core" \
  "($(cat "$work/t_keys_detect_searched") ms with every one searched);" \
  "keys_ffmpeg: $(cat "$work/t_keys_ffmpeg") ms to decode the key frames alone" \
  "($(cat "$work/t_keys_ffmpeg_unfiltered") ms without the loop filter)"
grep -h "examined" "$work/out_keys_detect.txt" | head -5 || true
grep -h "run time" "$work/out_register.txt" "$work/out_register_jpeg.txt" \
  "$work/out_register_jpeg_searched.txt" || true
python3 "$here/coarse_recall.py" "$work/det_every" "$work/det_coarse" recall
python3 "$here/coarse_recall.py" "$work/det_every" "$work/det_searched" recall_searched
for reg in reg_coarse reg_jpeg reg_jpeg_searched; do
  "$lookboth" evaluate "$work/$reg" --ground-truth "$work/site" --json "$work/$reg.eval.json" \
    --overwrite >/dev/null
  python3 - "$reg" "$work/$reg.eval.json" <<'PY'
import json, sys
e = json.load(open(sys.argv[2]))["ground_truth"]
print(f"{sys.argv[1]}: {len(e['cameras'])} cameras registered, position RMSE "
      f"{e['rms']['position_m'] * 100:.2f} cm, rotation {e['rms']['rotation_deg']:.3f} deg")
PY
done
