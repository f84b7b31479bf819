#!/usr/bin/env bash
# The second demo: data as a real site brings it. The robot's recording is a
# ROS 2 bag (MCAP, zstd chunks) and each ceiling camera's is a video file from
# its recorder; lookboth reads both without ROS and without extracting frames:
#   1. simulate `small` (rendered frames and ground truth) as a folder;
#   2. write the robot's part (fisheye PNG frames, odometry) as a ROS 2 MCAP bag
#      with the npm MCAP writer (scripts/ros2_fixtures/write_robot_mcap.mjs;
#      its packages go into a temporary folder: needs node, npm and the npm registry),
#      and each ceiling camera's frames as an H.264 MP4 (ffmpeg, as an NVR would);
#   3. import the bag (lookboth convert), add the videos with their calibrations
#      and start times (lookboth convert --video), register, evaluate against the
#      simulator's ground truth and write the report.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

lookboth_build lookboth
LOOKBOTH="$LOOKBOTH_BUILD_DIR/apps/lookboth/lookboth"
OUT="${LOOKBOTH_DEMO_OUT:-$LOOKBOTH_ROOT/out/demo_ros2_video}"
HERE="$LOOKBOTH_ROOT/scripts"
rm -rf "$OUT"
mkdir -p "$OUT/nvr"
npm_dir="$(mktemp -d)"
trap 'rm -rf "$npm_dir"' EXIT

echo "== 1. Simulate the 'small' scenario (rendered frames, ground truth)"
"$LOOKBOTH" simulate --scenario small --format folder --out "$OUT/simulated"
echo
echo "== 2. The recordings: the robot's ROS 2 bag, one H.264 video per ceiling camera"
(cd "$npm_dir" && npm init -y >/dev/null && npm install --no-audit --no-fund --silent \
  @mcap/core@2.2.2 @foxglove/rosmsg@5.0.5 @foxglove/rosmsg2-serialization@3.1.0 \
  @foxglove/wasm-zstd@1.0.1)
cp "$HERE/ros2_fixtures/write_robot_mcap.mjs" "$HERE/ros2_fixtures/ros2_schemas.mjs" "$npm_dir/"
node "$npm_dir/write_robot_mcap.mjs" "$OUT/simulated" "$OUT/robot.mcap"
video_args=()
for camera in "$OUT"/simulated/cameras/*/; do
  label=$(basename "$camera")
  cp -r "$camera" "$npm_dir/$label"
  python3 "$HERE/frames_to_video.py" "$npm_dir/$label"
  mv "$npm_dir/$label/video.mp4" "$OUT/nvr/$label.mp4"
  cp "$camera/calibration.yaml" "$OUT/nvr/$label.yaml"
  start=$(sed -n 's/^start_timestamp_ns: //p' "$npm_dir/$label/video.yaml")
  video_args+=(--video "$label=$OUT/nvr/$label.mp4:start=$start" --calibration "$label=$OUT/nvr/$label.yaml")
done
ls -l "$OUT/robot.mcap" "$OUT"/nvr/*.mp4
echo
echo "== 3. Import the bag, add the videos (no frames extracted), register"
"$LOOKBOTH" convert --from "$OUT/robot.mcap" --to "$OUT/robot" \
  --topic /fisheye/image/compressed=fisheye:fisheye --topic /odom=odometry:odometry \
  --marker DICT_4X4_50:7:0.2 --calibration "fisheye=$OUT/simulated/fisheye/calibration.yaml"
"$LOOKBOTH" convert --from "$OUT/robot" --to "$OUT/site" "${video_args[@]}"
"$LOOKBOTH" register "$OUT/site" --out "$OUT/registration"
echo
echo "== 4. Against the simulator's ground truth; the report"
"$LOOKBOTH" evaluate "$OUT/registration" --ground-truth "$OUT/simulated"
"$LOOKBOTH" report "$OUT/site" "$OUT/registration" --out "$OUT/report.html" \
  --ground-truth "$OUT/simulated"
echo
echo "Outputs in $OUT. Open the report in a browser: file://$(cd "$OUT" && pwd)/report.html"
