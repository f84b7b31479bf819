#!/usr/bin/env bash
# Video files as the cameras' recordings, end to end (doc/formats.md, "Video
# files"): every camera's frames encoded by ffmpeg as a recorder would
# (scripts/frames_to_video.py), registered straight from the videos.
#   cases.sh <lookboth binary> <case> <work dir>
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
# shellcheck source=../e2e_cases.sh
source "$ROOT/tests/e2e_cases.sh" "$@"
TO_VIDEO="$ROOT/scripts/frames_to_video.py"

case "$CASE" in

register_from_videos)
  "$L" simulate --scenario small --format folder --out site >/dev/null
  cp -r site videos
  # cam02's recorder dropped three frames in a row; cam04 is timed by a sidecar.
  python3 "$TO_VIDEO" videos/cameras/cam02 --drop 20,21,22
  python3 "$TO_VIDEO" videos/cameras/cam04 --timing sidecar
  for c in fisheye cameras/cam00 cameras/cam01 cameras/cam03 cameras/cam05; do
    python3 "$TO_VIDEO" "videos/$c"
  done
  [[ -z $(find videos -name '*.png') ]] || fail "PNG frames left in the video dataset"
  "$L" register videos --out reg 2>&1 | tee register.log
  grep -q "note: .*cam02/video.mp4: camera 'cam02': 3 frames missing in 1 gap" register.log ||
    fail "the dropped frames were not reported"
  "$L" evaluate reg --ground-truth site | tee evaluate.log
  # The images' registration is 0.74 cm; H.264 costs some of it (doc/formats.md).
  awk '$1 == "RMS" { exit !($2 < 0.025) }' evaluate.log || fail "camera position RMS over 2.5 cm"
  registered=$(grep -cE '^ *cam0[0-5] +registered' register.log || true)
  [[ $registered -eq 6 ]] || fail "$registered of 6 cameras registered"
  ;;

edge_node_video)
  # One camera's node holds its video alone; its detections merge like any other.
  "$L" simulate --scenario small --duration 12 --format folder --out site >/dev/null
  cam=$(cd site/cameras && wc -l -- */frames.csv | sort -n | sed -n 'x;$p' | awk '{print $2}')
  cam=${cam%%/*}
  "$L" convert --from site --to node --cameras "$cam" >/dev/null
  python3 "$TO_VIDEO" "node/cameras/$cam"
  "$L" detect node --detections-only --out det | tee detect.log
  "$L" detect site --detections-only --cameras "$cam" --out det_png >/dev/null
  video=$(tail -n +2 det/detections/markers.csv | wc -l)
  png=$(tail -n +2 det_png/detections/markers.csv | wc -l)
  echo "$cam: $video markers from the video, $png from the PNG frames"
  [[ $video -gt 0 && $video -ge $((png * 9 / 10)) ]] || fail "video $video markers, PNG $png"
  ;;

bad_videos)
  "$L" simulate --scenario small --duration 4 --format folder --out site >/dev/null
  # The fisheye's frames, as a camera of its own (the robot passes under none in 4 s).
  cp -r site v
  python3 "$TO_VIDEO" v/fisheye
  mv v/fisheye/video.yaml start.yaml
  if "$L" detect v --out x 2>err.txt; then fail "a video without times was accepted"; fi
  grep -q "fisheye/video.mp4.*the frames' times are unknown: add video.csv .* or video.yaml" err.txt ||
    { cat err.txt; fail "no clear message for a video without times"; }
  mv start.yaml v/fisheye/video.yaml
  head -c 3000 v/fisheye/video.mp4 >cut.mp4 && mv cut.mp4 v/fisheye/video.mp4
  if "$L" detect v --out x 2>err.txt; then fail "a cut video was accepted"; fi
  grep -q "fisheye/video.mp4: not a video file FFmpeg can read" err.txt ||
    { cat err.txt; fail "no clear message for a cut video"; }
  [[ ! -e x ]] || fail "a failed detect left its output"
  if "$L" convert --from site --to y --video fisheye=site/fisheye/frames.csv:start=0 2>err.txt; then
    fail "a CSV file was accepted as a video"
  fi
  grep -q "frames.csv: not a video file" err.txt || { cat err.txt; fail "unclear message"; }
  if "$L" convert --from site --to y --video fisheye=v/fisheye/video.mp4 2>err.txt; then
    fail "a video without times was accepted by convert"
  fi
  grep -q "add :times=FILE.csv .* or :start=NS" err.txt || { cat err.txt; fail "unclear message"; }
  [[ ! -e y ]] || fail "a failed convert left its output"
  ;;

*)
  fail "unknown case $CASE"
  ;;
esac
