#!/usr/bin/env bash
# Sets up, builds (Release) and runs lookboth's main job on the embedded
# default data. Today the pipeline that exists is the camera-model layer and
# the dataset layer, so the demo (1) self-checks every shipped calibration over
# its whole field of view, (2) converts a small recording from the plain folder
# layout into an MRPT rawlog dataset and back, and (3) has MRPT's rawlog-edit
# read that rawlog through lookboth's observation plugin. Later stages grow
# this script into simulate -> detect -> odometry -> register -> report.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

lookboth_build lookboth lookboth_obs
LOOKBOTH="$LOOKBOTH_BUILD_DIR/apps/lookboth/lookboth"
PLUGIN="$LOOKBOTH_BUILD_DIR/libs/obs/liblookboth-obs.so"
OUT="${LOOKBOTH_DEMO_OUT:-$LOOKBOTH_ROOT/out/demo}"
mkdir -p "$OUT"

echo "== lookboth $("$LOOKBOTH" --version | awk '{print $2}')"
echo "== 1. Camera models: project/unproject round trips over each model's whole field of view"
"$LOOKBOTH" camera check
echo
echo "== 2. Datasets: a small recording in the folder layout -> MRPT rawlog -> folder"
"$LOOKBOTH" convert --from "$LOOKBOTH_ROOT/tests/data/datasets/folder_small" --to "$OUT/small.rawlog" --overwrite
"$LOOKBOTH" convert --from "$OUT/small.rawlog" --to "$OUT/small_folder" --overwrite
"$LOOKBOTH" convert --from "$OUT/small.rawlog" --to "$OUT/ground_truth.tum" --label ground_truth --overwrite
echo
echo "== 3. MRPT's rawlog-edit reads the dataset through lookboth's plugin"
(cd "$OUT" && rawlog-edit -p "$PLUGIN" -i small.rawlog --info 2>&1 | grep -E "objects|labels|Sensor")
echo
echo "Outputs in $OUT"
