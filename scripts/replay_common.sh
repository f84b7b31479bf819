# Sourced by the scripts that replay real drives (bench_replay.sh,
# bench_update.sh, tests/replay/cases.sh): a scenario that drives a real
# ground truth with a real estimate as its odometry (robot.replay), the small
# scenario's cameras and detection noise, the facility sized to the path, one
# camera per 5 m of path; and the scenario of a later drive of a facility.
# Needs LOOKBOTH_ROOT (common.sh) and PASS_SHARE (the share of a marker
# detection's error its pass shares, noise.marker_pass_share).

# The extent of a TUM path's x and y after scaling [m] and its length [m].
extent() {
  python3 - "$1" "$2" <<'EOF'
import math, sys
path, scale = sys.argv[1], float(sys.argv[2])
xs, ys, length, last = [], [], 0.0, None
for line in open(path):
    if line.startswith('#') or not line.strip():
        continue
    f = line.split()
    p = (float(f[1]) * scale, float(f[2]) * scale)
    xs.append(p[0]); ys.append(p[1])
    if last: length += math.hypot(p[0] - last[0], p[1] - last[1])
    last = p
print(f"{max(xs) - min(xs):.2f} {max(ys) - min(ys):.2f} {length:.1f}")
EOF
}

# scenario <name> <dir> <scale> <metric> [odometry file, default dir/estimate.tum]
scenario() {
  local name=$1 dir=$2 scale=$3 metric=$4 odometry=${5:-$2/estimate.tum}
  read -r ex ey length < <(extent "$dir/groundtruth.tum" "$scale")
  local count
  count=$(python3 -c "print(max(4, round($length / 5)))")
  local world_x world_y
  world_x=$(python3 -c "print(round($ex + 3, 1))")
  world_y=$(python3 -c "print(round($ey + 3, 1))")
  sed -e "/^name:/s/.*/name: replay_$name/" \
    -e "/^description:/s|.*|description: replay of $name (scale $scale)|" \
    -e "s/^  length_m: .*/  length_m: $world_x/" \
    -e "s/^  width_m: .*/  width_m: $world_y/" \
    -e "s|^  loop: .*|  replay: {path: $dir/groundtruth.tum, odometry: $odometry, scale: $scale, metric: $metric}|" \
    -e "/^  corner_radius_m:/d" -e "/^  max_speed_mps:/d" -e "/^  max_acceleration_mps2:/d" \
    -e "/^  max_lateral_acceleration_mps2:/d" -e "/^  laps:/d" -e "/^  wait_s:/d" \
    -e "s/^  count: .*/  count: $count/" \
    -e "s/^noise: {/noise: {marker_pass_share: $PASS_SHARE, /" \
    "$LOOKBOTH_ROOT/share/lookboth/scenarios/small.yaml"
}

# later_drive <scenario file> <seed> <moved...>: the scenario of a later drive.
later_drive() {
  local scenario=$1 seed=$2
  shift 2
  sed 's/^name: \(.*\)/name: \1_later/' "$scenario"
  printf 'later_drive:\n  noise_seed: %s\n  moved:\n' "$seed"
  for move in "$@"; do printf '    - %s\n' "$move"; done
}
