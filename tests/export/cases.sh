#!/usr/bin/env bash
# End to end through `lookboth export` (doc/formats.md, "Exports"): a
# simulated registration exported in every format, each file read by its
# consumer from Debian: COLMAP (model_converter), urdfdom (check_urdf), a JSON
# Schema validator (python3-jsonschema), Python for the launch file, MRPT's
# graph-slam (mrpt-apps).
#   cases.sh <lookboth binary> <case> <work dir>
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
# shellcheck source=../e2e_cases.sh
source "$ROOT/tests/e2e_cases.sh" "$@"

registered() {
  "$L" simulate --scenario small --detections-only --out small.rawlog >/dev/null
  "$L" register small.rawlog --trajectory metric --out reg >/dev/null
}

# The poses COLMAP read (its own text output) against cameras.csv: cam_from_world.
compare_colmap() {
  python3 - "$1" reg/cameras.csv <<'PY'
import csv, math, sys
def qmul(a, b):
    aw, ax, ay, az = a; bw, bx, by, bz = b
    return (aw*bw - ax*bx - ay*by - az*bz, aw*bx + ax*bw + ay*bz - az*by,
            aw*by - ax*bz + ay*bw + az*bx, aw*bz + ax*by - ay*bx + az*bw)
def rotate(q, v):
    w, x, y, z = qmul(qmul(q, (0.0, *v)), (q[0], -q[1], -q[2], -q[3]))
    return (x, y, z)
truth = {r['label']: r for r in csv.DictReader(open(sys.argv[2]))}
seen = 0
lines = [l for l in open(sys.argv[1]) if not l.startswith('#')]
for line in lines[0::2]:
    f = line.split()
    q, t, name = tuple(map(float, f[1:5])), tuple(map(float, f[5:8])), f[9]
    r = truth[name]
    centre = (float(r['tx']), float(r['ty']), float(r['tz']))
    # cam_from_world maps the camera's centre to the origin.
    residual = [a + b for a, b in zip(rotate(q, centre), t)]
    qw = (float(r['qw']), float(r['qx']), float(r['qy']), float(r['qz']))
    # cam_from_world's rotation is world_from_camera's inverse.
    d = qmul(q, qw)
    # atan2 keeps full precision near zero, where acos(w) loses half the digits.
    angle = 2 * math.atan2(math.sqrt(d[1]**2 + d[2]**2 + d[3]**2), abs(d[0]))
    if max(map(abs, residual)) > 1e-9 or angle > 1e-9:
        sys.exit(f"FAIL: {name}: COLMAP's pose differs from cameras.csv ({residual}, {angle} rad)")
    seen += 1
if seen != len(truth):
    sys.exit(f"FAIL: {seen} images for {len(truth)} cameras")
print(f"colmap: {seen} images, cam_from_world = cameras.csv^-1 within 1e-9")
PY
}

case "$CASE" in

all_formats)
  registered
  "$L" export reg --format all --out exported | tee export.log
  for f in colmap/cameras.txt colmap/images.txt colmap/points3D.txt json/registration.json \
    opencv/cam00.yaml ros/site.urdf ros/static_transforms.launch.py ros/static_transforms.yaml \
    ros/camera_info/cam00_optical_frame.yaml mrpt/registration.graph mrpt/cameras_pdf.txt; do
    [[ -s exported/$f ]] || fail "exported/$f missing"
  done
  command -v colmap >/dev/null || fail "colmap is not installed (scripts/setup.sh installs it)"
  mkdir -p colmap_text
  colmap model_converter --input_path exported/colmap --output_path colmap_text \
    --output_type TXT >colmap.log 2>&1 || { cat colmap.log; fail "COLMAP cannot read the model"; }
  compare_colmap colmap_text/images.txt
  check_urdf exported/ros/site.urdf | tee urdf.log
  grep -q "root Link: site has 6 child(ren)" urdf.log || fail "the URDF does not hold 6 cameras"
  /usr/bin/python3 - "$SHARE/schema/registration_export.schema.json" \
    exported/json/registration.json <<'PY'
import json, sys, jsonschema
jsonschema.validate(json.load(open(sys.argv[2])), json.load(open(sys.argv[1])))
print("json: valid against", sys.argv[1].split('/')[-1])
PY
  python3 -m py_compile exported/ros/static_transforms.launch.py
  # MRPT's rawlog-edit reads each camera's pose PDF (CObservationRobotPose).
  rawlog-edit --info -i exported/mrpt/cameras.rawlog | tee rawlog.log
  grep -Eq "All sensor labels *: *cam00, cam01" rawlog.log || fail "rawlog-edit: $(tail -3 rawlog.log)"
  # MRPT's graph-slam reads the graph: its trajectory and camera nodes, and
  # edges made of the detections (graph-slam's own optimiser weighs every
  # edge alike; export/export checks MRPT's library optimiser, which weighs
  # them by their information, on the same file format).
  grep -Eq "note: registration.graph: [1-9][0-9]* marker detections in [1-9][0-9]* edges, [1-9][0-9]* blobs in [1-9][0-9]*" export.log ||
    fail "the graph's edges are not the detections: $(grep registration.graph export.log)"
  graph-slam --3d --info -i exported/mrpt/registration.graph | tee graph.log
  nodes=$(grep -E "Nodes count \(in VERTEX2/3 entries\)" graph.log | grep -Eo "[0-9]+$")
  poses=$(grep -vc "^#" reg/trajectory.tum)
  [[ $nodes -eq $((poses + 6)) ]] || fail "graph-slam read $nodes nodes, expected $poses poses and 6 cameras"
  ;;

refusals)
  registered
  "$L" export reg --format json --out one >/dev/null
  [[ -f one/registration.json ]] || fail "one format: its files straight in --out"
  if "$L" export reg --format json --out one 2>err.log; then fail "--out replaced without --overwrite"; fi
  grep -q "already exists" err.log || fail "no word on the existing output: $(cat err.log)"
  if "$L" export reg --format json,dxf --out two 2>err.log; then fail "an unknown format accepted"; fi
  grep -q "unknown format 'dxf'" err.log || fail "the unknown format is not named: $(cat err.log)"
  if "$L" export reg --format json --out reg --overwrite 2>err.log; then fail "wrote over its input"; fi
  [[ -f reg/registration.yaml ]] || fail "the registration was lost"
  [[ ! -e two ]] || fail "a failed export left 'two'"
  ;;

site_frame)
  # The floor frame's z against the simulator's vertical (the rotation of
  # lookboth evaluate's alignment to the ground truth), and control points.
  # register writes the floor frame by default; world_frame: registration
  # keeps the first fisheye pose's, which align --floor re-expresses.
  registered
  grep -q "^  name: floor" reg/registration.yaml || fail "register's default frame is not the floor"
  printf 'register:\n  world_frame: registration\n' >own_frame.yaml
  "$L" register small.rawlog --trajectory metric --config own_frame.yaml --out own >/dev/null
  grep -q "^  name: registration" own/registration.yaml || fail "world_frame: registration ignored"
  "$L" align own --floor --out floor | tee floor.log
  grep -q "world frame 'floor'" floor.log || fail "no floor frame"
  for run in own reg floor; do
    "$L" evaluate $run --ground-truth small.rawlog --json $run.eval.json >/dev/null
  done
  python3 - own.eval.json reg.eval.json floor.eval.json <<'PY'
import json, math, sys
def tilt(path):
    x, y, z, w = json.load(open(path))['ground_truth']['alignment']['rotation_xyzw']
    # z component of R e_z for the unit quaternion (x, y, z, w).
    return math.degrees(math.acos(min(1.0, 1 - 2 * (x * x + y * y))))
own, default, aligned = (tilt(p) for p in sys.argv[1:4])
print(f"vertical: registration frame {own:.3f} deg off, register's default (floor) "
      f"{default:.4f} deg, align --floor {aligned:.4f} deg")
if max(default, aligned) > 0.05:
    sys.exit("FAIL: a floor frame's z is more than 0.05 deg from the vertical")
PY
  # Control points: four cameras' true positions with 5 mm of noise, then one 10 cm off.
  "$L" convert --from small.rawlog --to folder >/dev/null
  python3 - folder/ground_truth/cameras.csv <<'PY'
import csv, random, sys
random.seed(3)
rows = list(csv.DictReader(open(sys.argv[1])))[:4]
with open('site.csv', 'w') as good, open('bad.csv', 'w') as bad:
    for f in (good, bad):
        f.write('name,x,y,z,sigma_m\n')
    for i, r in enumerate(rows):
        p = [float(r[k]) + random.gauss(0, 0.005) for k in ('tx', 'ty', 'tz')]
        good.write(f"{r['label']},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},0.005\n")
        if i == 2: p[0] += 0.10
        bad.write(f"{r['label']},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},0.005\n")
PY
  "$L" align reg --control-points site.csv --out site | tee site.log
  grep -q "world frame 'site'" site.log || fail "no site frame"
  # The report shows the site frame, each control point's residual and their plan view.
  "$L" report small.rawlog site --out site.html >/dev/null
  grep -q "<h2>World frame: site</h2>" site.html || fail "the report has no world frame section"
  for c in $(tail -n +2 site.csv | cut -d, -f1); do
    grep -q "<td class=l>$c</td>" site.html || fail "the report lists no residual of $c"
  done
  grep -q "<svg " site.html || fail "the report has no plan view of the residuals"
  if "$L" align reg --control-points bad.csv --out bad 2>bad.log; then fail "a point 10 cm off accepted"; fi
  grep -q "bad.csv:4: .*control point 'cam02' is" bad.log || fail "the bad point is not named: $(cat bad.log)"
  # The robot's dock (its position at the start of the drive) as a fifth
  # point, and a similarity: the scale comes out within its sigma of 1.
  python3 - folder/ground_truth/trajectory.tum <<'PY'
import random
random.seed(5)
first = next(l.split() for l in open(__import__('sys').argv[1]) if l.strip() and not l.startswith('#'))
p = [float(x) + random.gauss(0, 0.005) for x in first[1:4]]
lines = open('site.csv').read()
open('dock.csv', 'w').write(lines + f"@start,{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},0.005\n")
PY
  "$L" align reg --control-points dock.csv --with-scale --out dock | tee dock.log
  grep -q "^  @start " dock.log || fail "the dock's residual is not printed"
  python3 - dock/registration.yaml <<'PY'
import re, sys, yaml
frame = yaml.safe_load(open(sys.argv[1]))['world_frame']
scale, sigma = map(float, re.search(r"scale ([0-9.]+) \+- ([0-9.]+)", frame['description']).groups())
print(f"dock + 4 cameras, Sim(3): scale {scale:.6f} +- {sigma:.6f}")
if not (abs(scale - 1) < 4 * sigma and sigma < 0.01 and abs(frame['scale_from_registration'] - scale) < 1e-6):
    sys.exit("FAIL: the scale is off or not recorded")
PY
  ;;

fixed_markers)
  # Markers printed on the floor (scenario floor_markers) near four cameras,
  # detected by the cameras that see them: surveyed (5 mm of noise) they are
  # the control points ("marker:<id>"), which align locates from the
  # registered dataset's detections.
  "$L" simulate --scenario small --detections-only --out first.rawlog >/dev/null
  "$L" convert --from first.rawlog --to first >/dev/null
  python3 - "$SHARE/scenarios/small.yaml" first/ground_truth/cameras.csv <<'PY'
import csv, random, sys
random.seed(3)
rows = list(csv.DictReader(open(sys.argv[2])))[:4]
scenario = open(sys.argv[1]).read().replace('name: small', 'name: small_floor_markers', 1)
scenario += '\nfloor_markers:\n'
with open('site.csv', 'w') as site:
    site.write('name,x,y,z,sigma_m\n')
    for i, r in enumerate(rows):
        x, y = float(r['tx']) + 0.4, float(r['ty']) - 0.3
        scenario += f'  - {{id: {20 + i}, position_m: [{x:.3f}, {y:.3f}, 0.0], yaw_deg: {30 * i}, size_m: 0.3}}\n'
        p = [v + random.gauss(0, 0.005) for v in (x, y, 0.0)]
        site.write(f'marker:{20 + i},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},0.005\n')
open('floor_markers.yaml', 'w').write(scenario)
PY
  "$L" simulate --scenario floor_markers.yaml --detections-only --out drive.rawlog >/dev/null
  "$L" register drive.rawlog --trajectory metric --out reg >/dev/null
  "$L" align reg --control-points site.csv --out site | tee site.log
  for id in 20 21 22 23; do
    grep -Eq "^marker:$id: located from [1-9][0-9]* detections" site.log || fail "marker $id not located"
  done
  grep -q "world frame 'site'" site.log || fail "no site frame"
  "$L" convert --from drive.rawlog --to drive >/dev/null
  "$L" evaluate reg --ground-truth drive.rawlog --json reg.eval.json >/dev/null
  python3 - site/registration.yaml drive/ground_truth/cameras.csv reg.eval.json <<'PY'
import csv, json, math, sys, yaml
truth = {r['label']: [float(r[k]) for k in ('tx', 'ty', 'tz')] for r in csv.DictReader(open(sys.argv[2]))}
cameras = yaml.safe_load(open(sys.argv[1]))['cameras']
errors = [math.dist(c['world_from_camera']['translation'], truth[c['label']]) for c in cameras]
rms = math.sqrt(sum(e * e for e in errors) / len(errors))
own = json.load(open(sys.argv[3]))['ground_truth']['rms']['position_m']
print(f"site frame from 4 floor markers: cameras {rms * 1e3:.2f} mm RMS from their surveyed "
      f"positions (no alignment); the registration's own {own * 1e3:.2f} mm after the best one")
if rms > 0.02:
    sys.exit("FAIL: the site frame from the floor markers is more than 2 cm off")
PY
  # A marker no camera saw is named with its line.
  cp site.csv unseen.csv
  echo "marker:40,1,1,0,0.005" >>unseen.csv
  if "$L" align reg --control-points unseen.csv --out unseen 2>unseen.log; then fail "an unseen marker accepted"; fi
  grep -q "unseen.csv:6: .*'marker:40': no registered camera detected that marker" unseen.log ||
    fail "the unseen marker is not named: $(cat unseen.log)"
  ;;

recheck)
  # A later drive of the same facility (later_drive: new noise, cam03 moved
  # 6 cm, a shorter route) against the first: cam03 flagged, no other.
  "$L" simulate --scenario small --detections-only --out drive1.rawlog >/dev/null
  "$L" register drive1.rawlog --trajectory metric --out reg1 >/dev/null
  sed 's/^name: small/name: small_later/' "$SHARE/scenarios/small.yaml" >later.yaml
  printf 'later_drive:\n  noise_seed: 11\n  moved:\n    - {camera: cam03, translate_m: [0.06, 0, 0]}\n' >>later.yaml
  "$L" simulate --scenario later.yaml --detections-only --duration 28 --out drive2.rawlog >/dev/null
  "$L" register drive2.rawlog --trajectory metric --out reg2 >/dev/null
  "$L" check reg2 --against reg1 | tee check.log
  grep -q "^1 moved, 5 unchanged" check.log || fail "expected exactly one camera moved"
  grep -Eq "^  cam03 +moved" check.log || fail "cam03 is not the one flagged"
  # The same verdicts in the later drive's report, which says to act on them.
  "$L" report drive2.rawlog reg2 --record reg1 --out report.html --no-overview | tee report.log
  grep -q "1 camera(s) moved since the record" report.log || fail "the report's verdict misses the move"
  python3 - report.html <<'PY'
import re, sys
html = open(sys.argv[1]).read()
section = html.split("<h2>Re-check against the record")[1].split("<h2>")[0]
rows = re.findall(r"<tr[^>]*><td class=l>(cam\d+)</td><td class=l>([a-z ]+)</td>", section)
moved = [label for label, verdict in rows if verdict == "moved"]
if "1 moved, 5 unchanged" not in section or moved != ["cam03"] or len(rows) != 6:
    sys.exit(f"FAIL: the report's re-check: {rows}")
print("report: re-check section with cam03 moved, 5 unchanged")
PY
  # The record updated: cam03 from the later drive, in the record's frame.
  "$L" check reg2 --against reg1 --update-out updated >/dev/null
  "$L" evaluate updated --ground-truth drive2.rawlog --json updated.json >/dev/null
  "$L" evaluate reg1 --ground-truth drive2.rawlog --json stale.json >/dev/null
  python3 - stale.json updated.json <<'PY'
import json, sys
def cam03(path):
    return next(c for c in json.load(open(path))['ground_truth']['cameras'] if c['label'] == 'cam03')
stale, updated = cam03(sys.argv[1])['position_error_m'], cam03(sys.argv[2])['position_error_m']
print(f"cam03 against the later drive's truth: record {stale * 1000:.1f} mm, updated {updated * 1000:.1f} mm")
if not (stale > 0.04 and updated < 0.015):
    sys.exit("FAIL: the update did not bring cam03 back")
PY
  # register --update: cam03 registered again against the others held at the
  # record, in the record's frame: as near the later truth as this drive's own
  # registration puts it (the replacement above), far from the stale record;
  # the record is left untouched and registration.yaml says what was done.
  cp -r reg1 reg1.before
  "$L" register drive2.rawlog --trajectory metric --update reg1 --out reg3 | tee update.log
  grep -q "^update: against reg1: 1 moved and 0 new registered again, 5 unchanged held" update.log ||
    fail "the update's line: $(grep '^update' update.log)"
  grep -Eq "^  cam03 +moved" update.log || fail "the update did not name cam03"
  if "$L" register drive2.rawlog --trajectory metric --update reg1 --out reg1/updated 2>inside.log; then
    fail "register --update wrote inside the record"
  fi
  grep -q "is inside the record" inside.log || fail "the refusal: $(cat inside.log)"
  diff -r reg1 reg1.before >/dev/null || fail "register --update wrote into the record"
  "$L" evaluate reg3 --ground-truth drive2.rawlog --json reg3.json >/dev/null
  python3 - updated.json reg3.json reg3/registration.yaml <<'PY'
import json, sys, yaml
def cam03(path):
    return next(c for c in json.load(open(path))['ground_truth']['cameras'] if c['label'] == 'cam03')
replaced, updated = cam03(sys.argv[1])['position_error_m'], cam03(sys.argv[2])['position_error_m']
print(f"update: cam03 {updated * 1000:.1f} mm from the later truth (the drive alone: {replaced * 1000:.1f} mm)")
if not (updated < 0.01 and updated < replaced + 0.001):
    sys.exit("FAIL: the update did not bring cam03 back")
reg = yaml.safe_load(open(sys.argv[3]))
notes = [n for c in reg['cameras'] if c['label'] == 'cam03' for n in c.get('notes', [])]
held = [c['label'] for c in reg['cameras'] if any(n.startswith('update: unchanged') for n in c.get('notes', []))]
if not any(n.startswith('update: moved') for n in notes) or reg['pipeline'][-1] != 'update':
    sys.exit(f"FAIL: registration.yaml does not say what the update did: {notes}")
if len(held) != 5:
    sys.exit(f"FAIL: expected the 5 unchanged cameras held at the record: {held}")
PY
  # The simulator moved cam03 by exactly that and nothing else.
  python3 - drive1.yaml drive2.yaml <<'PY'
import sys, yaml
def truth(path):
    poses = yaml.safe_load(open(path))['ground_truth']['world_from_camera']
    return {k: [v['tx'], v['ty'], v['tz']] for k, v in poses.items()}
a, b = truth(sys.argv[1]), truth(sys.argv[2])
for label in a:
    d = [y - x for x, y in zip(a[label], b[label])]
    expected = [0.06, 0, 0] if label == 'cam03' else [0, 0, 0]
    if max(abs(x - e) for x, e in zip(d, expected)) > 1e-9:
        sys.exit(f"FAIL: {label} moved by {d} between the drives")
print("later drive: cam03 moved 6 cm, the other cameras where they were")
PY
  # A camera replaced by a new unit (later_drive replaced_by): its old label
  # not seen, the new one new, and the update registers the new one.
  sed 's/^name: small/name: small_replaced/' "$SHARE/scenarios/small.yaml" >replaced.yaml
  printf 'later_drive:\n  noise_seed: 12\n  moved:\n    - {camera: cam01, replaced_by: cam01b, translate_m: [0.01, 0, 0], rotate_deg: [0, 0, 2]}\n' >>replaced.yaml
  "$L" simulate --scenario replaced.yaml --detections-only --duration 28 --out drive4.rawlog >/dev/null
  "$L" register drive4.rawlog --trajectory metric --update reg1 --out reg4 | tee replaced.log
  grep -Eq "^  cam01 +not seen" replaced.log || fail "the replaced camera is not 'not seen'"
  grep -Eq "^  cam01b +new" replaced.log || fail "the new unit is not 'new'"
  grep -q "^update: against reg1: 0 moved and 1 new registered again, 5 unchanged held at the record, 1 not seen kept" replaced.log ||
    fail "the update's line: $(grep '^update' replaced.log)"
  ;;

studio)
  # $L is lookboth-studio here: a detections-only run through every stage,
  # then the floor frame and two export formats, as the File menu writes them.
  xvfb-run -a -s "-screen 0 1600x1000x24" "$L" --simulate small --detections-only --run-all \
    --simulate-out drive.rawlog --align-floor floor --export-formats json,colmap,mrpt=exported \
    --exit 2>studio.log ||
    { tail -20 studio.log; fail "the app failed"; }
  grep -q "Registration in the floor frame written" studio.log || fail "no floor frame: $(tail -5 studio.log)"
  grep -q "name: floor" floor/registration.yaml || fail "floor/registration.yaml is not in the floor frame"
  [[ -s exported/json/registration.json && -s exported/colmap/images.txt ]] ||
    fail "the exports are missing: $(ls -R exported 2>&1)"
  # MRPT's graph from the app's dataset index: the detections' edges.
  grep -Eq "note: registration.graph: [1-9][0-9]* marker detections in [1-9][0-9]* edges" studio.log ||
    fail "the app's graph is not made of the detections: $(grep registration.graph studio.log)"
  # File > Update the record: the same drive against that registration as the
  # record (nothing moved), written beside it; the record left as it was.
  # (The app writes each run's registration to drive_registration: the record is a copy.)
  [[ -f drive_registration/registration.yaml ]] || fail "no registration written: $(ls)"
  cp -r drive_registration record
  record=record
  dataset=drive.rawlog
  cp -r "$record" record.before
  xvfb-run -a -s "-screen 0 1600x1000x24" "$L" "$dataset" --trajectory metric --run-all \
    --update-record "$record=updated" --exit 2>update.log || { tail -20 update.log; fail "the update failed"; }
  grep -q "0 moved and 0 new registered again, 6 unchanged held at the record" update.log ||
    fail "the update's summary: $(grep -i update update.log | tail -3)"
  grep -q "update of the record" updated/registration.yaml ||
    fail "updated/registration.yaml has no update note"
  diff -r "$record" record.before >/dev/null || fail "the app wrote into the record"
  ;;

*)
  fail "unknown case '$CASE'"
  ;;
esac
