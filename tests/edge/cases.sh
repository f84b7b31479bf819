#!/usr/bin/env bash
# Detection on the edge nodes, end to end (doc/user-guide.md, "Detection on
# the edge nodes"): each camera's recording detected by its own process, the
# detections merged into the site's dataset, against one machine detecting
# the whole site.
#   cases.sh <lookboth binary> <case> <work dir>
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
# shellcheck source=../e2e_cases.sh
source "$ROOT/tests/e2e_cases.sh" "$@"

# The files of a detections-only folder dataset, by content.
detections() {
  (cd "$1" && find . -type f | sort | xargs sha256sum)
}

case "$CASE" in

nodes_equal_one_machine)
  "$L" simulate --scenario small --format folder --out site >/dev/null
  "$L" detect site --detections-only --out whole >/dev/null
  labels="fisheye $(ls site/cameras)"
  [[ $(wc -w <<<"$labels") -ge 3 ]] || fail "site/cameras holds: '$labels'"
  # What each node holds: its own camera's frames and calibration.
  for c in $labels; do "$L" convert --from site --to "node_$c" --cameras "$c" >/dev/null; done
  # One process per camera, two at a time, as a scheduler would start them.
  printf '%s\n' $labels |
    xargs -P 2 -I{} "$L" detect node_{} --detections-only --out det_{} >/dev/null
  for c in $labels; do
    [[ -z $(find "node_$c" -newer site/marker.yaml -path '*detections*') ]] ||
      fail "node_$c: detect wrote into its input"
  done
  size=$(du -sk det_* | awk '{s += $1} END {print s}')
  "$L" convert --merge det_* --to merged | tee merge.log
  diff <(detections whole) <(detections merged) || fail "merged detections differ from one machine's"
  echo "edge: $(wc -w <<<"$labels") nodes, ${size} KiB of detections sent; merged = one machine's"
  ;;

refusals)
  "$L" simulate --scenario small --detections-only --format folder --out site >/dev/null
  "$L" convert --from site --to a --cameras cam01 >/dev/null
  "$L" convert --from site --to b --cameras cam02 >/dev/null
  # Another marker: not the same recording.
  sed -i 's/^id: .*/id: 3/' b/marker.yaml
  grep -q '^id: 3' b/marker.yaml || fail "could not change b's marker id"
  if "$L" convert --merge a b --to m 2>err.txt; then fail "merged two markers"; fi
  grep -q "b: 'marker': another marker than 'a''s" err.txt || fail "message: $(cat err.txt)"
  [[ ! -e m ]] || fail "m was written"
  # The same camera's clock described differently: not comparable times.
  "$L" convert --from site --to d --cameras cam01,cam02 >/dev/null
  grep -q '^cam01,' d/ground_truth/clock_offsets.csv || fail "d has no clock offset of cam01"
  sed -i 's/^cam01,.*/cam01,123456/' d/ground_truth/clock_offsets.csv
  if "$L" convert --merge a d --to m 2>err.txt; then fail "merged two clocks of cam01"; fi
  grep -q "d: 'clock_offset': clock offset 123456 ns against .* ns in 'a'.* \[cam01\]" err.txt ||
    fail "message: $(cat err.txt)"
  [[ ! -e m ]] || fail "m was written"
  # An unknown camera for --cameras.
  if "$L" convert --from site --to c --cameras cam99 2>err.txt; then fail "took cam99"; fi
  grep -q "site: '--cameras': no such camera in the dataset (cameras: fisheye, cam00, .*) \[cam99\]" err.txt ||
    fail "message: $(cat err.txt)"
  # --detections-only needs an output.
  if "$L" detect a --detections-only 2>err.txt; then fail "detections-only in place"; fi
  grep -q "needs an output (--out)" err.txt || fail "message: $(cat err.txt)"
  echo "edge refusals: marker, clock, unknown camera, detections-only in place"
  ;;

*) fail "unknown case $CASE" ;;
esac
