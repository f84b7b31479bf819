#!/usr/bin/env bash
# Sets up, builds (Release) and runs lookboth's main job on the embedded
# default data. Today the pipeline that exists is the camera-model layer, so
# the demo self-checks every shipped calibration (the paper's fisheye as
# OCamCalib, Kannala-Brandt and double sphere; the environment cameras)
# over its whole field of view. Later stages grow this script into
# simulate -> detect -> odometry -> register -> report.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

lookboth_build lookboth
LOOKBOTH="$LOOKBOTH_BUILD_DIR/apps/lookboth/lookboth"

echo "== lookboth $("$LOOKBOTH" --version | awk '{print $2}')"
echo "== Camera models: project/unproject round trips over each model's whole field of view"
"$LOOKBOTH" camera check
echo
echo "== The paper's fisheye (OCamCalib calibration)"
"$LOOKBOTH" camera info "$LOOKBOTH_ROOT/share/lookboth/cameras/fisheye_calib_results.txt"
