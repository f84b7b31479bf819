#!/usr/bin/env bash
# End-to-end checks of the promises in doc/reliability.md: nothing the user
# gave is lost or overwritten, a stop is prompt, bad input gets a plain
# message. Each case runs in a fresh folder and exits non-zero on the first
# broken promise (77 = skipped: the machine cannot stage the case).
#   cases.sh <lookboth binary> <case> <work dir>
# shellcheck source=../e2e_cases.sh
source "$(dirname "${BASH_SOURCE[0]}")/../e2e_cases.sh" "$@"
# expect_error <regex> <command...>: exit 1 and the message matches.
expect_error() {
  local regex=$1
  shift
  local code=0
  "$@" >out.log 2>&1 || code=$?
  cat out.log
  [[ $code -eq 1 ]] || fail "exit $code (expected 1): $*"
  grep -Eq -- "$regex" out.log || fail "no '$regex' in the output of: $*"
}
tree_sum() { (cd "$1" && find . -type f -print0 | sort -z | xargs -0 md5sum | md5sum); }
file_sum() { md5sum "$@" | md5sum; }
rows() { grep -vc '^#' "$1" || true; }
# A small simulated dataset with frames (frames only near the robot).
with_frames() { "$L" simulate --scenario small --duration "${2:-4}" --out "$1" >/dev/null; }

case "$CASE" in

detect_keeps_detections)
  # A detections-only dataset has nothing to detect in: its detections stay.
  "$L" simulate --scenario small --detections-only --duration 5 --format folder --out ds >/dev/null
  before=$(tree_sum ds)
  expect_error "no frames to detect in" "$L" detect ds
  [[ "$(tree_sum ds)" == "$before" ]] || fail "detect changed a detections-only folder"
  "$L" simulate --scenario small --detections-only --duration 5 --out small.rawlog >/dev/null
  before=$(file_sum small.rawlog small.yaml)
  expect_error "no frames to detect in" "$L" detect small.rawlog
  [[ "$(file_sum small.rawlog small.yaml)" == "$before" ]] || fail "detect changed a rawlog"
  ;;

detect_stops_on_signal)
  # One Ctrl-C or SIGTERM stops detect promptly; the dataset is unchanged.
  with_frames img.rawlog 8
  before=$(file_sum img.rawlog img.yaml)
  for sig in INT TERM; do
    "$L" detect img.rawlog --threads 1 >"detect_$sig.log" 2>&1 &
    pid=$!
    # Signalled once it is working (its first progress line), not after a
    # fixed time: on a loaded machine loading the libraries alone can take
    # longer, and a signal before the handler exists is not what is tested.
    for _ in $(seq 300); do
      [[ -s "detect_$sig.log" ]] && break
      sleep 0.1
    done
    sleep 0.3
    kill -"$sig" "$pid"
    start=$(date +%s)
    code=0
    timeout 20 tail --pid="$pid" -f /dev/null || fail "detect still running 20 s after SIG$sig"
    wait "$pid" || code=$?
    cat "detect_$sig.log"
    [[ $code -eq 130 ]] || fail "detect exited $code after SIG$sig (expected 130)"
    echo "SIG$sig: stopped in $(($(date +%s) - start)) s"
  done
  [[ "$(file_sum img.rawlog img.yaml)" == "$before" ]] || fail "the stopped detect changed the dataset"
  ;;

outputs_never_inputs)
  "$L" simulate --scenario small --detections-only --out x.rawlog >/dev/null
  "$L" register x.rawlog --out reg --trajectory metric >/dev/null 2>&1 || fail "register"
  cp "$SHARE/cameras/fisheye_calib_results.txt" c.txt
  "$L" camera convert c.txt --out c.yaml >/dev/null
  "$L" convert --from x.rawlog --to ds >/dev/null
  before=$(file_sum x.rawlog x.yaml c.yaml)
  ds_before=$(tree_sum ds)
  expect_error "is the input" "$L" report x.rawlog reg --out x.rawlog
  expect_error "is the input" "$L" report x.rawlog reg --out ./x.rawlog --overwrite
  expect_error "is the input" "$L" evaluate reg --ground-truth x.rawlog --json x.rawlog
  expect_error "is the input" "$L" evaluate reg --ground-truth x.rawlog --json reg/cameras.csv --overwrite
  expect_error "is the input" "$L" camera convert c.yaml --out c.yaml
  expect_error "is the input" "$L" camera convert c.yaml --out ./c.yaml --overwrite
  expect_error "is the input" "$L" register x.rawlog --out x.rawlog --overwrite --trajectory metric
  expect_error "contains the input" "$L" register x.rawlog --out . --overwrite --trajectory metric
  expect_error "would overwrite the input" "$L" convert --from ds/ --to ds --overwrite
  expect_error "would overwrite the input" "$L" convert --from x.yaml --to x.rawlog --overwrite
  expect_error "is the input" "$L" snapshot x.rawlog reg --out reg
  expect_error "inside the input" "$L" snapshot x.rawlog reg --out reg/pictures
  [[ "$(file_sum x.rawlog x.yaml c.yaml)" == "$before" ]] || fail "an input was written to"
  [[ "$(tree_sum ds)" == "$ds_before" ]] || fail "the folder dataset was written to"
  # Existing outputs are replaced only with --overwrite.
  echo old >report.html
  echo old >e.json
  echo old >c2.yaml
  expect_error "already exists \(use --overwrite" "$L" report x.rawlog reg --out report.html
  expect_error "already exists \(use --overwrite" "$L" evaluate reg --ground-truth x.rawlog --json e.json
  expect_error "already exists \(use --overwrite" "$L" camera convert c.txt --out c2.yaml
  [[ "$(cat report.html e.json c2.yaml)" == "$(printf 'old\nold\nold')" ]] || fail "replaced"
  "$L" evaluate reg --ground-truth x.rawlog --json e.json --overwrite >/dev/null
  "$L" camera convert c.txt --out c2.yaml --overwrite >/dev/null
  grep -q model c2.yaml || fail "--overwrite did not replace c2.yaml"
  ;;

concurrent_writers)
  # Two in-place detect runs on different cameras: the second waits for the
  # first and keeps its results.
  "$L" simulate --scenario small --duration 6 --format folder --out ds >/dev/null
  rm -rf ds/detections
  "$L" detect ds --cameras fisheye --threads 1 >fisheye.log 2>&1 &
  pid=$!
  sleep 1
  "$L" detect ds --cameras cam03 --threads 1 >cam03.log 2>&1
  wait "$pid"
  cat fisheye.log cam03.log
  markers=$(rows ds/detections/markers.csv)
  blobs=$(rows ds/detections/blobs.csv)
  echo "markers rows: $markers, blob rows: $blobs"
  [[ $markers -gt 1 && $blobs -gt 1 ]] || fail "one run's detections were lost"
  # A writer holding the dataset's lock (here flock(1), as another run
  # would): detect waits for it, says so, then writes.
  flock .ds.lock sleep 3 &
  holder=$!
  sleep 0.5
  start=$(date +%s%N)
  "$L" detect ds --cameras cam04 --threads 1 >cam04.log 2>&1
  waited=$((($(date +%s%N) - start) / 1000000))
  wait "$holder"
  cat cam04.log
  grep -q "another lookboth run is rewriting it; waiting" cam04.log || fail "no wait announced"
  [[ $waited -gt 2000 ]] || fail "detect wrote while the lock was held ($waited ms)"
  [[ $(rows ds/detections/blobs.csv) -eq $blobs ]] || fail "the blobs were lost"
  ;;

register_write_back)
  # register says where it adds its detections; --no-write-back leaves the
  # dataset as it was and no temporary behind.
  "$L" simulate --scenario small --duration 15 --format folder --out ds >/dev/null
  rm -rf ds/detections
  before=$(tree_sum ds)
  "$L" register ds --out reg --trajectory metric --no-write-back >log 2>&1 || { cat log; fail "register"; }
  cat log
  grep -q "added to a temporary copy" log || fail "no word on where the detections went"
  [[ "$(tree_sum ds)" == "$before" ]] || fail "--no-write-back changed the dataset"
  [[ -z "$(find . -maxdepth 1 -name '.*tmp*')" ]] || fail "temporaries left: $(ls -a)"
  test -f reg/cameras.csv || fail "no registration"
  "$L" register ds --out reg2 --trajectory metric >log 2>&1 || { cat log; fail "register"; }
  grep -q "added to ds" log || fail "the write-back was not announced"
  test -f ds/detections/markers.csv || fail "no write-back"
  ;;

register_warns_dropped_rows)
  "$L" simulate --scenario small --detections-only --format folder --out ds >/dev/null
  # An odometry row out of order is dropped, with a word.
  f=ds/odometry/trajectory.tum
  line=$(grep -v '^#' "$f" | sed -n 3p)
  printf '%s\n' "$line" >>"$f"
  "$L" register ds --out reg --trajectory metric >log 2>&1 || true
  cat log
  grep -q "warning: .*$(basename "$f")" log || fail "register dropped a row without a warning"
  ;;

frame_size)
  # A fisheye frame of the wrong size is skipped with a word, and a
  # 30000x30000 PNG is refused from its header, not decoded (2.7 GB).
  "$L" simulate --scenario small --duration 3 --format folder --out ds >/dev/null
  rm -rf ds/detections
  frames=(ds/fisheye/frames/*.png)
  python3 - "${frames[0]}" "${frames[1]}" <<'PY'
import struct, sys, zlib
def png(path, w, h):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    z = zlib.compressobj(1)
    row = b"\0" * (w + 1)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)))
        data = b"".join(z.compress(row) for _ in range(h)) + z.flush()
        f.write(chunk(b"IDAT", data) + chunk(b"IEND", b""))
png(sys.argv[1], 30000, 30000)
png(sys.argv[2], 1500, 900)
PY
  /usr/bin/time -f "max RSS %M KB" "$L" detect ds --threads 1 >log 2>&1 || { cat log; fail "detect"; }
  cat log
  grep -q "is 30000x30000, the calibration .*frame skipped" log || fail "huge frame not refused"
  grep -q "is 1500x900, the calibration .*frame skipped" log || fail "wrong-size frame not refused"
  rss=$(sed -n 's/max RSS \([0-9]*\) KB/\1/p' log)
  [[ $rss -lt 400000 ]] || fail "max RSS $rss KB: the huge frame was decoded"
  ;;

config_errors)
  "$L" simulate --scenario small --detections-only --duration 5 --out x.rawlog >/dev/null
  printf 'registr:\n  joint: {rounds: 2}\n' >typo.yaml
  expect_error "typo.yaml:1: 'registr': unknown key" "$L" register x.rawlog --out r --config typo.yaml
  : >empty.yaml
  expect_error "empty.yaml: the configuration file is empty" "$L" register x.rawlog --out r --config empty.yaml
  printf '# only a comment\n' >comment.yaml
  expect_error "comment.yaml: the configuration file holds no section" "$L" register x.rawlog --out r --config comment.yaml
  printf 'register:\n  joint:\n    rounds: 1000000000\n' >rounds.yaml
  expect_error "rounds.yaml:3: 'register.joint.rounds': 'rounds': must be 1-100" "$L" register x.rawlog --out r --config rounds.yaml
  printf 'register:\n  joint:\n    rounds: 99999999999\n' >big.yaml
  expect_error "big.yaml:3: .*out of range" "$L" register x.rawlog --out r --config big.yaml
  printf 'detect:\n  markers:\n    max_speed_mps: -1\n' >range.yaml
  expect_error "range.yaml:[0-9]+:" "$L" detect x.rawlog --config range.yaml --dry-run
  [[ ! -e r ]] || fail "an output was written"
  ;;

csv_messages)
  # A byte-order mark is not part of the first column; a huge bad field is
  # not echoed whole.
  "$L" simulate --scenario small --detections-only --format folder --out ds >/dev/null
  f=ds/detections/markers.csv
  printf '\xEF\xBB\xBF' | cat - "$f" >bom.csv && mv bom.csv "$f"
  "$L" register ds --out reg --trajectory metric >log 2>&1 || { cat log; fail "BOM refused"; }
  python3 - "$f" <<'PY'
import sys
lines = open(sys.argv[1], encoding="utf-8-sig").read().splitlines()
fields = lines[2].split(",")
fields[2] = "x" * 20_000_000
lines[2] = ",".join(fields)
open(sys.argv[1], "w").write("\n".join(lines) + "\n")
PY
  code=0
  "$L" register ds --out reg2 --trajectory metric >log 2>&1 || code=$?
  [[ $code -eq 1 ]] || fail "exit $code for a bad field"
  size=$(wc -c <log)
  head -c 600 log
  [[ $size -lt 20000 ]] || fail "the message is $size bytes: the field was echoed whole"
  grep -q "characters)" log || fail "the field's length is not said"
  ;;

environment_errors)
  # A full disk and a read-only folder are the user's to fix: exit 1 with a
  # plain message, not "internal error" and an MRPT dump.
  mkdir -p small ro
  if ! mount -t tmpfs -o size=48k tmpfs small 2>/dev/null; then
    echo "cannot mount a tmpfs here: skipped"
    exit 77
  fi
  trap 'umount "$WORK/small" "$WORK/ro" 2>/dev/null || true' EXIT
  code=0
  "$L" simulate --scenario small --detections-only --duration 20 --out small/x.rawlog >log 2>&1 || code=$?
  cat log
  [[ $code -eq 1 ]] || fail "disk full: exit $code (expected 1)"
  grep -q "internal error\|MRPT exception" log && fail "disk full: not a plain message"
  [[ -z "$(ls -A small)" ]] || fail "disk full left files: $(ls -A small)"
  code=0
  "$L" simulate --scenario small --detections-only --duration 20 --format folder --out small/ds >log 2>&1 || code=$?
  cat log
  [[ $code -eq 1 ]] || fail "disk full (folder): exit $code (expected 1)"
  grep -q "internal error\|MRPT exception" log && fail "disk full (folder): not a plain message"
  mount -t tmpfs -o ro tmpfs ro
  code=0
  "$L" simulate --scenario small --detections-only --duration 5 --out ro/x.rawlog >log 2>&1 || code=$?
  cat log
  [[ $code -eq 1 ]] || fail "read-only: exit $code (expected 1)"
  grep -q "internal error\|MRPT exception" log && fail "read-only: not a plain message"
  ;;

stale_temporaries)
  # A run killed with SIGKILL leaves a hidden temporary; the next run that
  # writes into the folder removes it.
  "$L" simulate --scenario small --detections-only --out x.rawlog >/dev/null
  touch -d '2 hours ago' .x.rawlog.tmp-999999999-0
  mkdir .reg.tmp-999999999 && touch -d '2 hours ago' .reg.tmp-999999999
  "$L" register x.rawlog --out reg --trajectory metric >/dev/null 2>&1 || fail "register"
  [[ -z "$(find . -maxdepth 1 -name '.*tmp-999999999*')" ]] || fail "stale temporaries stayed: $(ls -a)"
  ;;

*)
  fail "unknown case '$CASE'"
  ;;
esac
echo "ok: $CASE"
