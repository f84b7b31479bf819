#!/usr/bin/env bash
# End to end through a replay (robot.replay, doc/formats.md): a drive and an
# estimate of it are written as TUM files, scripts/bench_replay.sh simulates
# the replay, registers it (true path, estimate, paper's stages) and
# evaluates each; the case checks the accuracy and that the registration's
# predicted error is honest (measured/predicted RMSE and the positions'
# NEES per degree of freedom).
#   cases.sh <lookboth binary> <case> <work dir>
#
# turn_drift: the drive is ours, not a real recording: its estimate drifts as
# the real ones in doc/benchmarks.md do, mostly in the turns (a heading
# error per turn, which the position error integrates), with a jump back at
# a loop closure half-way. real_mh04: a real estimate of a real drive
# (tests/data/real_trajectories), held to the targets of doc/benchmarks.md.
# keyframes_mh04: the same estimate kept only at irregular keyframe-like
# times (0.3-2 s apart, as ORB-SLAM's KeyFrameTrajectory.txt), held to the
# same targets. update_mh04: the same drive registered, then a later one with another
# trial's estimate and two cameras moved, updated against it.
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
# shellcheck source=../e2e_cases.sh
source "$ROOT/tests/e2e_cases.sh" "$@"

# Two laps of a 9 m x 5 m rounded rectangle at 0.6 m/s, 20 Hz.
write_drive() {
  mkdir -p "$1"
  python3 - "$1" <<'EOF'
import math, sys
out = sys.argv[1]
a, b, r, v, rate = 9.0, 5.0, 1.0, 0.6, 20.0
straight = [a - 2 * r, b - 2 * r, a - 2 * r, b - 2 * r]
lap = sum(straight) + 2 * math.pi * r
def point(s):
    s %= lap
    x, y, h = r, 0.0, 0.0
    for side in range(4):
        if s <= straight[side]:
            return x + s * math.cos(h), y + s * math.sin(h), h
        x += straight[side] * math.cos(h); y += straight[side] * math.sin(h); s -= straight[side]
        if s <= math.pi / 2 * r:
            t = s / r
            cx, cy = x - r * math.sin(h), y + r * math.cos(h)
            return cx + r * math.sin(h + t), cy - r * math.cos(h + t), h + t
        cx, cy = x - r * math.sin(h), y + r * math.cos(h)
        h += math.pi / 2
        x, y = cx + r * math.sin(h), cy - r * math.cos(h)
        s -= math.pi / 2 * r
    return x, y, h
def quat(yaw):
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
n = int(2 * lap / v * rate)
t0 = 1600000000.0
err_yaw, err = 0.0, [0.0, 0.0]
prev = point(0)
with open(out + '/groundtruth.tum', 'w') as g, open(out + '/estimate.tum', 'w') as e:
    for k in range(n + 1):
        t = t0 + k / rate
        x, y, h = point(v * k / rate)
        # The estimate: 1.5 % of each turn lost in heading, plus a slow bias.
        dh = h - prev[2]
        err_yaw += -0.015 * dh + math.radians(0.002)
        dx, dy = x - prev[0], y - prev[1]
        c, s_ = math.cos(err_yaw), math.sin(err_yaw)
        err[0] += (c - 1) * dx - s_ * dy
        err[1] += s_ * dx + (c - 1) * dy
        if k == n // 2:  # loop closure: half the error taken back at once
            err = [0.5 * err[0], 0.5 * err[1]]
            err_yaw *= 0.5
        prev = (x, y, h)
        qx, qy, qz, qw = quat(h)
        g.write(f"{t:.6f} {x:.6f} {y:.6f} 1.000000 {qx:.9f} {qy:.9f} {qz:.9f} {qw:.9f}\n")
        qx, qy, qz, qw = quat(h + err_yaw)
        e.write(f"{t:.6f} {x + err[0]:.6f} {y + err[1]:.6f} 1.000000 "
                f"{qx:.9f} {qy:.9f} {qz:.9f} {qw:.9f}\n")
EOF
}

# check <run dir> <max position RMSE [m]> [floor run dir] [max rotation RMSE [deg]]:
# prints the figures; fails outside the bounds (with a floor: also above twice
# the floor's RMSE, and the predicted error held to doc/benchmarks.md's
# targets, [0.67, 1.5]).
check() {
  python3 - "$@" <<'EOF'
import json, sys, yaml
reg, max_rmse = sys.argv[1], float(sys.argv[2])
floor = sys.argv[3] if len(sys.argv) > 3 else None
max_rotation = float(sys.argv[4]) if len(sys.argv) > 4 else None
e = json.load(open(reg + '/eval.json'))['ground_truth']
r = yaml.safe_load(open(reg + '/registration.yaml'))
rmse = e['rms']['position_m']
predicted = r['observability']['aligned_position_rmse_m']
nees = e['position_nees_per_dof']
rotation = e['rms']['rotation_deg']
print(f"{reg}: position RMSE {rmse * 1000:.2f} mm, predicted {predicted * 1000:.2f} mm, "
      f"ratio {rmse / predicted:.2f}, NEES/dof {nees:.2f}, rotation RMSE {rotation:.3f} deg")
problems = []
if rmse > max_rmse: problems.append(f"RMSE above {max_rmse * 1000:.1f} mm")
if max_rotation is not None and rotation > max_rotation:
    problems.append(f"rotation RMSE above {max_rotation:.3f} deg")
if floor:
    floor_rmse = json.load(open(floor + '/eval.json'))['ground_truth']['rms']['position_m']
    print(f"  {rmse / floor_rmse:.2f}x the floor's {floor_rmse * 1000:.2f} mm")
    if rmse > 2 * floor_rmse: problems.append("RMSE above twice the floor's")
    ratio, nees_range = (0.67, 1.5), (0.67, 1.5)
else:
    ratio, nees_range = (0.5, 2.0), (0.3, 3.0)
if not ratio[0] <= rmse / predicted <= ratio[1]:
    problems.append(f"measured/predicted outside {list(ratio)}")
if not nees_range[0] <= nees <= nees_range[1]:
    problems.append(f"NEES/dof outside {list(nees_range)}")
if problems:
    sys.exit("FAIL: " + "; ".join(problems))
EOF
}

case "$CASE" in

turn_drift)
  write_drive data/turn_drift
  LOOKBOTH_BIN=$L bash "$ROOT/scripts/bench_replay.sh" data runs | tee bench.log
  check runs/turn_drift.floor 0.005
  check runs/turn_drift.real 0.010
  grep -q "turn_drift paper" bench.log || fail "the paper's stages did not run"
  ;;

real_mh04)
  # A real estimate of a real drive (tests/data/real_trajectories/README.md):
  # the targets of doc/benchmarks.md's "Real drift" on one recording.
  mkdir -p data
  cp -r "$ROOT/tests/data/real_trajectories/euroc_mh04_vislam_rp" data/
  LOOKBOTH_BIN=$L bash "$ROOT/scripts/bench_replay.sh" data runs | tee bench.log
  check runs/euroc_mh04_vislam_rp.floor 0.006
  # Rotation (target 0.2 deg): 0.18 deg with the clocks held within the
  # nodes' NTP synchronisation (joint.clock_prior_sigma_s) and the clock
  # search not fooled by the drift, 0.21 with the search moving three
  # cameras by 50-190 ms, 0.30 with a weak prior as well.
  check runs/euroc_mh04_vislam_rp.real 0.015 runs/euroc_mh04_vislam_rp.floor 0.2
  grep -q "euroc_mh04_vislam_rp paper" bench.log || fail "the paper's stages did not run"
  ;;

keyframes_mh04)
  # A keyframe trajectory: the joint adds nodes between the samples, which
  # the detections bend, the motion held smooth (joint.between_samples_*).
  # The intervals cycle through 0.3-2 s (median 0.38 s; ORB-SLAM's fr2/desk
  # keyframes: median 0.37 s, 22 of 155 over 1 s). 0.57 cm 0.13 deg against
  # a floor of 0.46 cm, predicted 0.62 cm; 57.8 cm (NEES/dof 451) without
  # the added nodes (node_interval_s: 0).
  dir=data/mh04_keyframes
  mkdir -p $dir
  cp "$ROOT/tests/data/real_trajectories/euroc_mh04_vislam_rp/groundtruth.tum" $dir/
  python3 - "$ROOT/tests/data/real_trajectories/euroc_mh04_vislam_rp/estimate.tum" \
    $dir/estimate.tum <<'EOF'
import sys
intervals = [0.3, 0.35, 0.45, 0.3, 1.2, 0.4, 0.35, 0.5, 2.0, 0.3, 0.4, 0.8]  # [s]
lines = [l for l in open(sys.argv[1]) if not l.startswith('#')]
kept, last = [], None
for line in lines:
    t = float(line.split()[0])
    if last is None or t - last >= intervals[len(kept) % len(intervals)] - 1e-6:
        kept.append(line)
        last = t
if kept[-1] is not lines[-1]:
    kept.append(lines[-1])
open(sys.argv[2], 'w').writelines(kept)
print(f"{len(kept)} of {len(lines)} estimate poses kept as keyframes")
EOF
  LOOKBOTH_BIN=$L bash "$ROOT/scripts/bench_replay.sh" data runs | tee bench.log
  check runs/mh04_keyframes.real 0.015 runs/mh04_keyframes.floor 0.2
  ;;

update_mh04)
  # register --update on a real drift (doc/benchmarks.md, "Updating the
  # record"): the record from the replay with trial 0 of a real VI-SLAM as
  # odometry, the later drive with its trial 1 and cam07 3 cm down, cam12
  # turned 1 deg. Both are flagged and brought back: cam07 within the
  # record's own error, cam12's rotation by at least 0.2 of its 1 deg (a weak
  # camera: 16 detections on record); the registrations' 9 mm errors let at most two unmoved cameras
  # past the check (scripts/bench_update.sh's seeds: one or two, cam09's
  # later registration off by 2.7 deg with a wrong clock).
  LOOKBOTH_ROOT=$ROOT
  PASS_SHARE=0.15
  # shellcheck source=../../scripts/replay_common.sh
  source "$ROOT/scripts/replay_common.sh"
  dir=$ROOT/tests/data/real_trajectories/euroc_mh04_vislam_rp
  sed 's/^    blob_pass_error_share: .*/    blob_pass_error_share: 0/' \
    "$ROOT/share/lookboth/config/default.yaml" >config.yaml
  scenario mh04 "$dir" 1 true >first_scenario.yaml
  "$L" simulate --scenario first_scenario.yaml --detections-only --out first.rawlog >/dev/null 2>&1
  "$L" register first.rawlog --config config.yaml --out record >/dev/null 2>&1
  scenario mh04 "$dir" 1 true "$dir/estimate_later.tum" >base_scenario.yaml
  later_drive base_scenario.yaml 101 "{camera: cam07, translate_m: [0, 0, -0.03]}" \
    "{camera: cam12, rotate_deg: [1, 0, 0]}" >later_scenario.yaml
  "$L" simulate --scenario later_scenario.yaml --detections-only --out later.rawlog >/dev/null 2>&1
  "$L" register later.rawlog --config config.yaml --update record --out updated >update.log 2>&1 ||
    fail "register --update: $(tail -3 update.log)"
  grep -E '^  cam[0-9]+ +moved' update.log | awk '{print $1}' >flagged.txt
  "$L" evaluate record --ground-truth first.rawlog --json record.json >/dev/null
  "$L" evaluate record --ground-truth later.rawlog --json stale.json >/dev/null
  "$L" evaluate updated --ground-truth later.rawlog --json updated.json >/dev/null
  python3 - <<'EOF'
import json, sys
flagged = open('flagged.txt').read().split()
def cams(path):
    return {c['label']: c for c in json.load(open(path))['ground_truth']['cameras']}
record, stale, updated = cams('record.json'), cams('stale.json'), cams('updated.json')
worst = max(c['position_error_m'] for c in record.values())
pos = lambda c: c['position_error_m'] * 1000
print(f"flagged {flagged}; cam07 (moved 3 cm) {pos(stale['cam07']):.1f} mm stale, "
      f"{pos(updated['cam07']):.1f} mm updated; cam12 (turned 1 deg) "
      f"{stale['cam12']['rotation_error_deg']:.3f} deg stale, "
      f"{updated['cam12']['rotation_error_deg']:.3f} deg updated; the record's cameras at most "
      f"{worst * 1000:.1f} mm from their truth")
problems = []
if not {'cam07', 'cam12'} <= set(flagged): problems.append("a moved camera not flagged")
if len(set(flagged) - {'cam07', 'cam12'}) > 2: problems.append("more than two false alarms")
if updated['cam07']['position_error_m'] > min(worst, 0.5 * stale['cam07']['position_error_m']):
    problems.append("cam07 not brought back")
if updated['cam12']['rotation_error_deg'] > stale['cam12']['rotation_error_deg'] - 0.2:
    problems.append("cam12's rotation not brought back")
if problems:
    sys.exit("FAIL: " + "; ".join(problems))
EOF
  ;;

*)
  fail "unknown case '$CASE'"
  ;;
esac
