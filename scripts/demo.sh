#!/usr/bin/env bash
# Sets up, builds (Release) and runs lookboth's main job on the embedded
# default, the simulator's `small` scenario, end to end:
#   1. simulate `small` (rendered fisheye and environment-camera frames, ground truth)
#      into an MRPT rawlog dataset;
#   2. self-check every shipped camera calibration;
#   3. convert the dataset to the plain folder layout and the ground truth to TUM,
#      and let MRPT's rawlog-edit read it through lookboth's plugin;
#   4. detect the marker in the environment cameras and the cameras in the fisheye
#      (and score the detections against the ground truth);
#   5. run the fisheye visual odometry;
#   6. register the cameras (the default: the paper's stages, then the joint
#      adjustment), with the visual trajectory and with the robot's wheel
#      odometry; and once more with the paper's stages alone (config/paper.yaml);
#   7. evaluate against the ground truth, compare the runs, draw the pictures
#      and write the HTML report;
#   8. express the registration in the floor's frame and export it for the
#      systems that use it (COLMAP, JSON, OpenCV, ROS 2, MRPT).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

lookboth_build lookboth lookboth_obs
LOOKBOTH="$LOOKBOTH_BUILD_DIR/apps/lookboth/lookboth"
PLUGIN="$LOOKBOTH_BUILD_DIR/libs/obs/liblookboth-obs.so"
OUT="${LOOKBOTH_DEMO_OUT:-$LOOKBOTH_ROOT/out/demo}"
mkdir -p "$OUT"

echo "== lookboth $("$LOOKBOTH" --version | awk '{print $2}')"
echo "== 1. Simulate the 'small' scenario (6 ceiling cameras, a 22 m loop, rendered frames, ground truth)"
"$LOOKBOTH" simulate --scenario small --out "$OUT/small.rawlog" --overwrite
echo
echo "== 2. Camera models: project/unproject round trips over each model's whole field of view"
"$LOOKBOTH" camera check --samples 2000
echo
echo "== 3. The dataset in the plain folder layout, the ground-truth trajectory as TUM, MRPT reads it"
"$LOOKBOTH" convert --from "$OUT/small.rawlog" --to "$OUT/small_folder" --overwrite
"$LOOKBOTH" convert --from "$OUT/small.rawlog" --to "$OUT/ground_truth.tum" --label ground_truth --overwrite
(cd "$OUT" && rawlog-edit -p "$PLUGIN" -i small.rawlog --info 2>&1 | grep -E "objects|labels|Sensor")
echo
echo "== 4. Detect: the marker in every environment camera, the cameras (blobs) in the fisheye"
"$LOOKBOTH" detect "$OUT/small.rawlog" --evaluate
echo
echo "== 5. Visual odometry on the fisheye (trajectory 'vo', up to scale, added to the dataset)"
"$LOOKBOTH" odometry "$OUT/small.rawlog"
echo
echo "== 6. Register the cameras (the paper's stages, then the joint adjustment): visual trajectory,"
echo "==    then the wheel odometry (metric), then the visual trajectory with the paper's stages alone"
"$LOOKBOTH" register "$OUT/small.rawlog" --out "$OUT/registration" --overwrite
"$LOOKBOTH" register "$OUT/small.rawlog" --trajectory metric --out "$OUT/registration_metric" --overwrite
"$LOOKBOTH" register "$OUT/small.rawlog" --out "$OUT/registration_paper" --overwrite \
  --config "$LOOKBOTH_ROOT/share/lookboth/config/paper.yaml"
echo
echo "== 7. Evaluate against the simulator's ground truth, and the two runs against each other"
"$LOOKBOTH" evaluate "$OUT/registration" --ground-truth "$OUT/small.rawlog"
"$LOOKBOTH" evaluate "$OUT/registration" --against "$OUT/registration_metric"
"$LOOKBOTH" evaluate "$OUT/registration_paper" --ground-truth "$OUT/small.rawlog"
echo
echo "== Pictures without a display: reprojection checks, camera views, 3-D overview, comparison"
"$LOOKBOTH" snapshot "$OUT/small.rawlog" "$OUT/registration" --out "$OUT/pictures" \
  --ground-truth "$OUT/small.rawlog"
echo
echo "== The report: one self-contained HTML file"
"$LOOKBOTH" report "$OUT/small.rawlog" "$OUT/registration" --out "$OUT/report.html" --overwrite \
  --ground-truth "$OUT/small.rawlog" --against "$OUT/registration_metric"
echo
echo "== Hand on: the registration in the floor's frame, exported for COLMAP, JSON, OpenCV, ROS 2, MRPT"
"$LOOKBOTH" align "$OUT/registration" --floor --out "$OUT/registration_floor" --overwrite
"$LOOKBOTH" export "$OUT/registration_floor" --format all --out "$OUT/exports" --overwrite
echo
echo "Outputs in $OUT. Open the report in a browser: file://$(cd "$OUT" && pwd)/report.html"
