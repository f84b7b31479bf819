#!/usr/bin/env bash
# Registration on replays of real drives (doc/benchmarks.md, "Real drift").
#
#   scripts/bench_replay.sh [data dir] [work dir]
#
# The data dir holds one folder per recording, each with groundtruth.tum (a
# real ground truth) and estimate.tum (a real estimator's output for the same
# drive), as scripts/derive_real_trajectories.py writes them; default
# $LOOKBOTH_REAL_TRAJECTORIES, else ../shared/data/real_trajectories. For each
# recording the script writes a replay scenario (robot.replay; the small
# scenario's cameras and detection noise, the facility sized to the path, one
# camera per 5 m of path), simulates it (detections only), registers it three
# ways and evaluates each against the ground truth:
#   floor   the true path as a metric trajectory;
#   real    the replayed estimate (metric, or visual mode when its scale is unknown);
#   paper   the same with config/paper.yaml (the paper's stages alone).
# The floor and real runs get default.yaml with blob_pass_error_share: 0 (the
# simulated blobs are independent), or $LOOKBOTH_REPLAY_CONFIG when set, as
# --config (an experiment with the joint's options). It prints one line per run: position and rotation RMSE, the registration's
# predicted position RMSE, their ratio and the positions' NEES per degree of
# freedom (lookboth evaluate). Recordings whose name contains
# "_mono" but come from a metric estimator are listed in METRIC below.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
source "$(dirname "${BASH_SOURCE[0]}")/replay_common.sh"

data=${1:-${LOOKBOTH_REAL_TRAJECTORIES:-$LOOKBOTH_ROOT/../shared/data/real_trajectories}}
work=${2:-$(mktemp -d "${TMPDIR:-/tmp}/lookboth-replay.XXXXXX")}
lookboth=${LOOKBOTH_BIN:-$LOOKBOTH_ROOT/build/apps/lookboth/lookboth}
config=()
if [[ -n ${LOOKBOTH_REPLAY_CONFIG:-} ]]; then config=(--config "$LOOKBOTH_REPLAY_CONFIG"); fi
if [[ ! -d $data ]]; then
  echo "bench_replay.sh: no recordings in '$data' (see scripts/derive_real_trajectories.py)" >&2
  exit 2
fi
mkdir -p "$work"
data=$(cd "$data" && pwd)  # the scenarios name its files from elsewhere
# The simulator's blobs are independent (it shares only the markers' errors
# within a pass, noise.marker_pass_share below): the joint is told so.
if [[ ${#config[@]} -eq 0 ]]; then
  sed 's/^    blob_pass_error_share: .*/    blob_pass_error_share: 0/' \
    "$LOOKBOTH_ROOT/share/lookboth/config/default.yaml" >"$work/replay_config.yaml"
  config=(--config "$work/replay_config.yaml")
fi

# Per recording: the scale that makes it a robot-sized drive, and whether
# its estimate is metric. A hand-held desk sequence (4 m across) is tripled,
# the small EuRoC room (6 m) doubled; the machine hall is kept as it is.
declare -A SCALE=([tum_fr2_desk_orbslam_mono]=3 [euroc_v203_vio_mono]=2)
declare -A METRIC=([tum_fr2_desk_orbslam_mono]=false)
# The share of a marker detection's error its pass shares, as our detector's
# on rendered recordings (noise.marker_pass_share, doc/formats.md);
# $LOOKBOTH_REPLAY_PASS_SHARE=0 gives independent detections.
PASS_SHARE=${LOOKBOTH_REPLAY_PASS_SHARE:-0.15}

evaluate() {
  local label=$1 reg=$2 truth=$3
  if ! "$lookboth" evaluate "$reg" --ground-truth "$truth" --json "$reg/eval.json" \
    >"$reg.evaluate.log" 2>&1; then
    echo "$label: not evaluated: $(tail -1 "$reg.evaluate.log")"
    return 0
  fi
  python3 - "$label" "$reg" <<'EOF'
import json, sys, yaml
label, reg = sys.argv[1], sys.argv[2]
e = json.load(open(reg + '/eval.json'))['ground_truth']
r = yaml.safe_load(open(reg + '/registration.yaml'))
pos = e['rms']['position_m']
rot = e['rms']['rotation_deg']
pred = (r.get('observability') or {}).get('aligned_position_rmse_m')
n = len(e['cameras'])
ratio = f"{pos / pred:.2f}" if pred else "-"
nees = e.get('position_nees_per_dof')
print(f"{label:40s} cameras {n:>3}  position {pos * 100:6.2f} cm  rotation {rot:5.3f} deg  "
      f"predicted {pred * 100 if pred else float('nan'):5.2f} cm  measured/predicted {ratio}"
      + (f"  NEES/dof {nees:.2f}" if nees is not None else ""))
EOF
}

for dir in "$data"/*/; do
  dir=${dir%/}
  name=$(basename "$dir")
  [[ -f $dir/groundtruth.tum && -f $dir/estimate.tum ]] || continue
  scale=${SCALE[$name]:-1}
  metric=${METRIC[$name]:-true}
  scenario "$name" "$dir" "$scale" "$metric" >"$work/$name.scenario.yaml"
  "$lookboth" simulate --scenario "$work/$name.scenario.yaml" --detections-only \
    --out "$work/$name.rawlog" --overwrite >"$work/$name.simulate.log"
  "$lookboth" register "$work/$name.rawlog" --trajectory metric --trajectory-label ground_truth \
    "${config[@]}" --out "$work/$name.floor" --overwrite >"$work/$name.floor.log" 2>&1
  evaluate "$name floor" "$work/$name.floor" "$work/$name.rawlog"
  "$lookboth" register "$work/$name.rawlog" "${config[@]}" --out "$work/$name.real" --overwrite \
    >"$work/$name.real.log" 2>&1
  evaluate "$name real ($([[ $metric == true ]] && echo metric || echo visual))" \
    "$work/$name.real" "$work/$name.rawlog"
  if "$lookboth" register "$work/$name.rawlog" --config "$LOOKBOTH_ROOT/share/lookboth/config/paper.yaml" \
    --out "$work/$name.paper" --overwrite >"$work/$name.paper.log" 2>&1; then
    evaluate "$name paper" "$work/$name.paper" "$work/$name.rawlog"
  else
    echo "$name paper: register failed ($work/$name.paper.log)"
  fi
done
echo "work: $work"
