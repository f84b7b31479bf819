#!/usr/bin/env bash
# Sets up, builds (Release) and runs lookboth's main job on the embedded
# default: the simulator's `small` scenario. Today the pipeline that exists is
# simulate -> dataset; the demo (1) simulates `small` (rendered fisheye and
# environment-camera frames, ground truth) into an MRPT rawlog dataset,
# (2) self-checks every shipped camera calibration over its whole field of
# view, (3) converts the dataset to the plain folder layout and exports the
# ground-truth trajectory as TUM, and (4) has MRPT's rawlog-edit read the
# dataset through lookboth's observation plugin. Later stages grow this
# script into simulate -> detect -> odometry -> register -> report.
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
echo "== 3. The dataset in the plain folder layout, and the ground-truth trajectory as TUM"
"$LOOKBOTH" convert --from "$OUT/small.rawlog" --to "$OUT/small_folder" --overwrite
"$LOOKBOTH" convert --from "$OUT/small.rawlog" --to "$OUT/ground_truth.tum" --label ground_truth --overwrite
echo
echo "== 4. MRPT's rawlog-edit reads the dataset through lookboth's plugin"
(cd "$OUT" && rawlog-edit -p "$PLUGIN" -i small.rawlog --info 2>&1 | grep -E "objects|labels|Sensor")
echo
echo "== 5. Detect the marker in the ceiling cameras' frames and the housings in the fisheye's, scored against the ground truth"
"$LOOKBOTH" detect "$OUT/small.rawlog" --evaluate
echo
echo "Outputs in $OUT (frames in $OUT/small_Images)"

# Checking the registration (libs/report). Runs once a registration exists in
# $OUT/registration (written by the register step: `lookboth register ... --out "$OUT/registration"`).
if [[ -f "$OUT/registration/registration.yaml" ]]; then
  echo
  echo "== Evaluate the registration against the simulator's ground truth (paper's Tables I and II)"
  "$LOOKBOTH" evaluate "$OUT/registration" --ground-truth "$OUT/small.rawlog"
  echo
  echo "== Pictures without a display: reprojection checks, camera views, 3-D overview, comparison"
  "$LOOKBOTH" snapshot "$OUT/small.rawlog" "$OUT/registration" --out "$OUT/pictures" \
    --ground-truth "$OUT/small.rawlog"
  echo
  echo "== The report: one self-contained HTML file"
  "$LOOKBOTH" report "$OUT/small.rawlog" "$OUT/registration" --out "$OUT/report.html" \
    --ground-truth "$OUT/small.rawlog"
  echo
  echo "Open the report in a browser: file://$(cd "$OUT" && pwd)/report.html"
fi
