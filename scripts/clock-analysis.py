#!/usr/bin/env python3
"""Clock offsets and rotations of a registration against a simulated dataset.

For each camera: the clock offset's error against the simulator's
(ground_truth.clock_offsets_ns of the manifest), its reported sigma and the
normalised error z = error / sigma; then, when the registration directory
holds evaluation.json (`lookboth evaluate REG --ground-truth DATASET`), the
camera tilt that the clock error would explain (a clock error dt moves the
marker by v dt along the path, which a tilt of v dt / h of a camera h above
it mimics) against the camera's rotation error. With two TUM files, the RMS
error of the trajectory's rotation increments over 1-100 frames (how much of
a trajectory's attitude error is frame-to-frame jitter and how much drift).

usage: clock-analysis.py MANIFEST.yaml REGISTRATION_DIR [SPEED_M_S HEIGHT_M]
       clock-analysis.py --increments ESTIMATE.tum REFERENCE.tum
"""
import bisect
import json
import math
import os
import sys

import yaml


def clocks(manifest_path, registration_dir, speed, height):
    manifest = yaml.safe_load(open(manifest_path))
    truth = manifest["ground_truth"]["clock_offsets_ns"]
    registration = yaml.safe_load(open(os.path.join(registration_dir, "registration.yaml")))
    errors = {}
    z2 = []
    for camera in registration["cameras"]:
        label = camera["label"]
        offset = camera.get("clock_offset")
        if not offset or label not in truth or "sigma_ms" not in offset:
            continue
        error = (offset["offset_ns"] - truth[label]) * 1e-6
        z = error / offset["sigma_ms"]
        errors[label] = error
        z2.append(z * z)
        print("%s clock error %8.2f ms  sigma %6.3f ms  z %7.1f" % (label, error, offset["sigma_ms"], z))
    if not errors:
        sys.exit("no estimated clock offsets with sigmas and ground truth")
    rms = math.sqrt(sum(e * e for e in errors.values()) / len(errors))
    print("clock offsets: RMS error %.2f ms, mean z^2 %.1f over %d cameras" % (rms, sum(z2) / len(z2), len(z2)))
    evaluation = os.path.join(registration_dir, "evaluation.json")
    if not os.path.exists(evaluation):
        return
    tilt, rotation = [], []
    for camera in json.load(open(evaluation))["ground_truth"]["cameras"]:
        if camera["label"] in errors:
            tilt.append(math.degrees(abs(errors[camera["label"]]) * 1e-3 * speed / height))
            rotation.append(camera["rotation_error_deg"])
    n = len(tilt)
    mt, mr = sum(tilt) / n, sum(rotation) / n
    cov = sum((a - mt) * (b - mr) for a, b in zip(tilt, rotation))
    corr = cov / math.sqrt(sum((a - mt) ** 2 for a in tilt) * sum((b - mr) ** 2 for b in rotation))
    print("tilt the clock errors explain (v %.2f m/s, h %.2f m): RMS %.3f deg; rotation error RMS %.3f deg; "
          "correlation of the two over %d cameras %.2f"
          % (speed, height, math.sqrt(sum(t * t for t in tilt) / n),
             math.sqrt(sum(r * r for r in rotation) / n), n, corr))


def load_tum(path):
    times, quaternions = [], []
    for line in open(path):
        if line.startswith("#") or not line.strip():
            continue
        v = [float(x) for x in line.split()]
        times.append(v[0])
        quaternions.append((v[7], v[4], v[5], v[6]))  # w x y z
    return times, quaternions


def multiply(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


def conjugate(q):
    return (q[0], -q[1], -q[2], -q[3])


def angle_deg(q):
    return math.degrees(2 * math.atan2(math.sqrt(q[1] ** 2 + q[2] ** 2 + q[3] ** 2), abs(q[0])))


def increments(estimate_path, reference_path):
    tr, qr = load_tum(reference_path)
    te, qe = load_tum(estimate_path)
    est, ref = [], []
    for t, q in zip(te, qe):
        i = bisect.bisect_left(tr, t - 1e-5)
        if i < len(tr) and abs(tr[i] - t) < 1e-4:
            est.append(q)
            ref.append(qr[i])
    print("%d poses at common times" % len(est))
    for lag in (1, 3, 10, 30, 100):
        errors = []
        for i in range(len(est) - lag):
            d_ref = multiply(conjugate(ref[i]), ref[i + lag])
            d_est = multiply(conjugate(est[i]), est[i + lag])
            errors.append(angle_deg(multiply(conjugate(d_ref), d_est)))
        if errors:
            print("lag %3d frames: RMS rotation increment error %.4f deg"
                  % (lag, math.sqrt(sum(e * e for e in errors) / len(errors))))


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--increments":
        increments(sys.argv[2], sys.argv[3])
    elif len(sys.argv) in (3, 5):
        speed = float(sys.argv[3]) if len(sys.argv) == 5 else 0.78
        height = float(sys.argv[4]) if len(sys.argv) == 5 else 3.0
        clocks(sys.argv[1], sys.argv[2], speed, height)
    else:
        sys.exit(__doc__.strip().split("\n\n")[-1])


if __name__ == "__main__":
    main()
