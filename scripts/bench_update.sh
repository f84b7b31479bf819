#!/usr/bin/env bash
# `lookboth register <later drive> --update <record>` against registering the
# facility whole (doc/benchmarks.md, "Updating the record").
#
#   scripts/bench_update.sh [work dir] [real data dir]
#
# 1. `paper` (detections only): the first drive (the whole route) registered;
#    later drives of its first 40 s (later_drive: noise_seed 101-105; cam28
#    3 cm along x, cam32 3 cm down, cam36 turned 1 deg), each registered with
#    --update against the first: the cameras it flags, the moved cameras'
#    position and rotation error against the later drive's truth, and the
#    record's own errors against its truth (`lookboth evaluate`).
# 2. Time: `register` of the first drive and `register --update` of a later
#    one, alternated 3 times on a quiet machine; medians of the wall clock.
# 3. A real drift: the replay of EuRoC MH_04 (replay_common.sh), the first
#    drive's odometry a VI-SLAM's trial 0, the later drive's its trial 1
#    (estimate_later.tum, scripts/derive_real_trajectories.py), cam02 3 cm
#    along x, cam07 3 cm down, cam12 turned 1 deg; seeds 101-103.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
source "$(dirname "${BASH_SOURCE[0]}")/bench_common.sh"
source "$(dirname "${BASH_SOURCE[0]}")/replay_common.sh"

work=${1:-$(mktemp -d "${TMPDIR:-/tmp}/lookboth-update.XXXXXX")}
data=${2:-${LOOKBOTH_REAL_TRAJECTORIES:-$LOOKBOTH_ROOT/../shared/data/real_trajectories}}
lookboth=${LOOKBOTH_BIN:-$LOOKBOTH_ROOT/build/apps/lookboth/lookboth}
PASS_SHARE=0.15
mkdir -p "$work"
cd "$work"

# report <label> <record> <record truth> <update> <update truth> <moved labels...>
report() {
  local label=$1 record=$2 record_truth=$3 update=$4 update_truth=$5
  shift 5
  "$lookboth" evaluate "$record" --ground-truth "$record_truth" --json record.json --overwrite >/dev/null
  "$lookboth" evaluate "$update" --ground-truth "$update_truth" --json update.json --overwrite >/dev/null
  python3 - "$label" "$update/flagged.txt" "$*" <<'EOF'
import json, math, sys
label, flagged, moved = sys.argv[1], open(sys.argv[2]).read().split(), sys.argv[3].split()
def cams(path):
    return {c['label']: c for c in json.load(open(path))['ground_truth']['cameras']}
record, update = cams('record.json'), cams('update.json')
rms = lambda v: math.sqrt(sum(x * x for x in v) / len(v))
rec_pos = [c['position_error_m'] for c in record.values()]
rec_rot = [c['rotation_error_deg'] for c in record.values()]
moved_txt = ", ".join(f"{m} {update[m]['position_error_m'] * 1000:.1f} mm {update[m]['rotation_error_deg']:.3f} deg"
                      for m in moved)
print(f"{label}: flagged {' '.join(flagged) or 'none'} ({'exactly the moved' if sorted(flagged) == sorted(moved) else 'NOT the moved ' + ' '.join(moved)}); "
      f"moved after the update: {moved_txt}; record vs its truth: {rms(rec_pos) * 1000:.1f} mm RMS "
      f"({max(rec_pos) * 1000:.1f} max), {rms(rec_rot):.3f} deg RMS ({max(rec_rot):.3f} max)")
EOF
}

# update <dataset> <record> <out> [register options...]: register --update, the flagged cameras kept.
update() {
  local dataset=$1 record=$2 out=$3
  shift 3
  "$lookboth" register "$dataset" --update "$record" --out "$out" --overwrite "$@" >"$out.log" 2>&1
  grep -E '^  cam[0-9]+ +moved' "$out.log" | awk '{print $1}' >"$out/flagged.txt" || true
}

echo "== paper: the first 40 s driven again, 3 cameras moved"
"$lookboth" simulate --scenario paper --detections-only --out first.rawlog --overwrite >/dev/null 2>&1
"$lookboth" register first.rawlog --out record --overwrite >record.log 2>&1
MOVES=("{camera: cam28, translate_m: [0.03, 0, 0]}" "{camera: cam32, translate_m: [0, 0, -0.03]}"
  "{camera: cam36, rotate_deg: [1, 0, 0]}")
for seed in 101 102 103 104 105; do
  later_drive "$LOOKBOTH_ROOT/share/lookboth/scenarios/paper.yaml" "$seed" "${MOVES[@]}" >later.yaml
  "$lookboth" simulate --scenario later.yaml --detections-only --duration 40 \
    --out "later$seed.rawlog" --overwrite >/dev/null 2>&1
  update "later$seed.rawlog" record "update$seed"
  report "paper seed $seed" record first.rawlog "update$seed" "later$seed.rawlog" cam28 cam32 cam36
done

echo "== time (wall clock, medians of 3 alternated)"
wait_for_quiet_machine
full=() part=()
for i in 1 2 3; do
  /usr/bin/time -f %e -o time.txt "$lookboth" register first.rawlog --out timed_full --overwrite \
    >/dev/null 2>&1
  full+=("$(cat time.txt)")
  /usr/bin/time -f %e -o time.txt "$lookboth" register later101.rawlog --update record \
    --out timed_update --overwrite >/dev/null 2>&1
  part+=("$(cat time.txt)")
done
python3 - "${full[*]}" "${part[*]}" <<'EOF'
import statistics, sys
full, part = (sorted(float(x) for x in a.split()) for a in sys.argv[1:3])
f, p = statistics.median(full), statistics.median(part)
print(f"register of the first drive (193 s, 43 cameras): {f:.2f} s {full}; register --update of a "
      f"40 s later drive: {p:.2f} s {part}; ratio {p / f:.2f}")
EOF

echo "== real drift: EuRoC MH_04's replay, the later drive with another trial's odometry"
dir=$data/euroc_mh04_vislam_rp
if [[ ! -f $dir/estimate_later.tum ]]; then
  echo "no $dir/estimate_later.tum (scripts/derive_real_trajectories.py): skipped"
  exit 0
fi
dir=$(cd "$dir" && pwd)
sed 's/^    blob_pass_error_share: .*/    blob_pass_error_share: 0/' \
  "$LOOKBOTH_ROOT/share/lookboth/config/default.yaml" >replay_config.yaml
scenario mh04 "$dir" 1 true >mh04_scenario.yaml
"$lookboth" simulate --scenario mh04_scenario.yaml --detections-only --out mh04.rawlog --overwrite >/dev/null 2>&1
"$lookboth" register mh04.rawlog --config replay_config.yaml --out mh04_record --overwrite \
  >mh04_record.log 2>&1
MOVES=("{camera: cam02, translate_m: [0.03, 0, 0]}" "{camera: cam07, translate_m: [0, 0, -0.03]}"
  "{camera: cam12, rotate_deg: [1, 0, 0]}")
for seed in 101 102 103; do
  scenario mh04 "$dir" 1 true "$dir/estimate_later.tum" >mh04_later_base.yaml
  later_drive mh04_later_base.yaml "$seed" "${MOVES[@]}" >mh04_later.yaml
  "$lookboth" simulate --scenario mh04_later.yaml --detections-only \
    --out "mh04_later$seed.rawlog" --overwrite >/dev/null 2>&1
  update "mh04_later$seed.rawlog" mh04_record "mh04_update$seed" --config replay_config.yaml
  report "MH_04 seed $seed" mh04_record mh04.rawlog "mh04_update$seed" "mh04_later$seed.rawlog" \
    cam02 cam07 cam12
done
echo "work: $work"
