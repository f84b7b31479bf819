#!/usr/bin/env bash
# End-to-end checks of a technician's first hour (doc/user-guide.md, "Your
# first hour"): the default command does the right thing with the data a
# user brings, and its output says what to act on and nothing else.
#   cases.sh <lookboth binary> <case> <work dir>
# shellcheck source=../e2e_cases.sh
source "$(dirname "${BASH_SOURCE[0]}")/../e2e_cases.sh" "$@"
# expect <regex> <file>: the file has a line matching it.
expect() { grep -Eq -- "$1" "$2" || fail "no '$1' in $2"; }
# Position RMSE [mm] of `lookboth evaluate` against the dataset's ground truth.
position_rmse_mm() {
  "$L" evaluate "$1" --ground-truth "$2" --json eval.json >/dev/null
  python3 -c "import json; print(round(1000 * json.load(open('eval.json'))['ground_truth']['rms']['position_m'], 2))"
}
# Warnings of the registration and of the reading (a warning may wrap onto
# more lines; its first says "warning:").
warning_lines() { grep -Ec "^ *(- )?warning: |^lookboth: warning: " "$1" || true; }

case "$CASE" in

unscaled_trajectory)
  # The user's own trajectory, marked up to scale (a monocular SLAM's), and
  # no fisheye frames: the plain command uses it in visual mode and says so.
  "$L" simulate --scenario small --detections-only --format folder --out ds >/dev/null
  sed -i 's/^metric: true/metric: false/' ds/odometry/odometry.yaml
  expect "^metric: false" ds/odometry/odometry.yaml
  "$L" register ds --out reg >out.log 2>&1 || { cat out.log; fail "register exited non-zero"; }
  cat out.log
  expect "^trajectory: its only trajectory up to scale, 'odometry' \(visual mode" out.log
  expect "registered 6 of 6 cameras .* with the visual trajectory 'odometry'" out.log
  rmse=$(position_rmse_mm reg ds)
  echo "position RMSE against ground truth: $rmse mm"
  python3 -c "import sys; sys.exit(0 if $rmse < 10 else 1)" || fail "position RMSE $rmse mm"
  ;;

clean_run)
  # A clean simulated run: nothing to act on, the report's verdict is ok.
  "$L" simulate --scenario small --detections-only --out small.rawlog >/dev/null
  "$L" register small.rawlog --out reg >out.log 2>&1 || { cat out.log; fail "register failed"; }
  cat out.log
  expect "^trajectory: its metric trajectory 'odometry'" out.log
  expect "^warnings: none" out.log
  [[ $(warning_lines out.log) -le 3 ]] || fail "$(warning_lines out.log) warning lines"
  "$L" report small.rawlog reg --out report.html >report.log 2>&1 || {
    cat report.log
    fail "report failed"
  }
  expect "Verdict: ok" report.html
  ;;

clock_fault)
  # One camera's clock 150 ms off: the one warning of the run names it.
  sed '/^noise:/a faults: {clock_jump: {node: cam03, offset_ms: 150}}' \
    "$SHARE/scenarios/small.yaml" >scenario_clock.yaml
  "$L" simulate --scenario scenario_clock.yaml --detections-only --out clock.rawlog >/dev/null
  "$L" register clock.rawlog --out reg >out.log 2>&1 || { cat out.log; fail "register failed"; }
  cat out.log
  expect "^warnings: 1" out.log
  [[ $(warning_lines out.log) -eq 1 ]] || fail "more than the clock's warning"
  expect "warning: cam03: joint: clock offset 1[45][0-9][.][0-9] ms" out.log
  expect "^cam03 .* registered .*1 warning below" out.log
  ;;

guide)
  # The user guide's walk-through, as printed, with this build's binary.
  guide="$(dirname "${BASH_SOURCE[0]}")/../../doc/user-guide.md"
  sed -n '/first-hour:begin/,/first-hour:end/p' "$guide" | sed -n 's/^lookboth /"$L" /p' >walk.sh
  [[ $(wc -l <walk.sh) -ge 4 ]] || fail "no walk-through in $guide"
  cat walk.sh
  L=$L bash -e walk.sh >out.log 2>&1 || { cat out.log; fail "the walk-through failed"; }
  cat out.log
  expect "^trajectory: visual odometry on its fisheye frames" out.log
  expect "^detect: [0-9]+ marker detections, [0-9]+ fisheye frames with blobs added to site" out.log
  expect "^odometry: [0-9]+ poses added as trajectory 'vo' to site" out.log
  expect "registered 6 of 6 cameras" out.log
  expect "^run time: detect [0-9.]+ s, odometry [0-9.]+ s, stages [0-9.]+ s, output [0-9.]+ s; [0-9.]+ s in all, [0-9.]+x the drive \(36\.[0-9] s\)" out.log
  expect "^warnings: none" out.log
  expect "Verdict: ok" site_report.html
  ;;

*)
  fail "no case '$CASE'"
  ;;
esac
echo "ok: $CASE"
