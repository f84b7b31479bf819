#!/usr/bin/env python3
"""Derive small TUM files of REAL odometry/SLAM estimates and their ground truth.

Reads pinned commits of three public repositories from bare git mirrors (with
`git show <commit>:<path>`, nothing else), and writes, per sequence,

    <out>/<short_name>/estimate.tum      the estimate, values as published
    <out>/<short_name>/groundtruth.tum   the ground truth over the same span

plus <out>/README.md with the sources, the licences found, the derivation rules
and facts measured here (path length, duration, ATE after SE(3)/Sim(3) Umeyama
alignment).

What is done to the data (and nothing else):
  * both files are clipped to the time span where estimate AND ground truth exist
    (+-0.1 ms, since copies round the same instant differently);
  * the estimate keeps original samples whose spacing is >= the period (a 20 Hz
    cap, lowered to 10, 6.7, 5 ... Hz only when a file would exceed the size
    limit); no interpolation, no alignment, no rescaling: its drift is the point;
  * the ground truth keeps original samples too: the one nearest to each kept
    estimate time (within 20 ms), so every estimate pose keeps its ground-truth
    partner, and in the estimate's holes (e.g. keyframe-only estimates) the one
    nearest to each point of a grid of the same period, spaced >= that period;
  * numbers are re-printed as `t tx ty tz qx qy qz qw` with 9 / 6 / 9 decimals
    (timestamps are carried as exact decimals, never through binary floats).

Usage (python3 standard library only):
    python3 scripts/derive_real_trajectories.py \\
        --rpg      /work/.mirror/uzh-rpg+rpg_trajectory_evaluation/repo \\
        --openvins /work/.mirror/rpng+open_vins/repo \\
        --evo      /work/.mirror/MichaelGrupp+evo/repo \\
        --out      DIR
"""

import argparse
import bisect
import decimal
import math
import os
import subprocess
import sys

SIZE_LIMIT = 148_000          # bytes per written file ("under ~150 KB")
BASE_PERIOD = decimal.Decimal("0.05")   # 20 Hz cap
SPACING_TOLERANCE = 0.001     # s: a sample 49.x ms after the last kept one still counts as 50 ms
ASSOC_MAX_DT = 0.02           # s: estimate <-> ground truth association (TUM benchmark convention)
CLIP_TOLERANCE = decimal.Decimal("0.0001")  # s: stamps of one instant differ by rounding (10 us in some copies)
NS = decimal.Decimal("0.000000001")

# --------------------------------------------------------------------------------------
# Sources (pinned). The blob of every file read is also printed into the README.
# --------------------------------------------------------------------------------------
REPOS = {
    "rpg": {
        "name": "uzh-rpg/rpg_trajectory_evaluation",
        "commit": "8c8ceec55c5c5094a6494208cfc5f54afe0bbc4d",
        "licence": "MIT (`LICENSE`: \"MIT License, Copyright (c) 2018 Zichao Zhang (Robotics and "
                   "Perception Group, University of Zurich, Switzerland)\"; `package.xml`: "
                   "`<license>MIT</license>`). No separate statement covers the files under `results/`.",
    },
    "openvins": {
        "name": "rpng/open_vins",
        "commit": "69488123ed9362dd44b6f28e7f4680abbff1442b",
        "licence": "GPL-3.0 (`LICENSE`: GNU General Public License v3; `ov_data/package.xml`: "
                   "`<license>GNU General Public License v3.0</license>`, described as \"Data for the "
                   "OpenVINS project, mostly just groundtruth files...\").",
    },
    "evo": {
        "name": "MichaelGrupp/evo",
        "commit": "26d0953d4da0f0cb56f90ba6269a15e72f69d3ad",
        "licence": "GPL-3.0 (`LICENSE`: GNU General Public License v3). No separate statement covers "
                   "`test/data/`.",
    },
}

RPG_EUROC = "results/euroc_mono_stereo/laptop"
RPG_VISLAM = "results/euroc_vislam_mono/laptop"
OV = "ov_data/euroc_mav"

EUROC_DATASET = ("EuRoC MAV dataset (Burri et al., \"The EuRoC micro aerial vehicle datasets\", "
                 "IJRR 35(10), 2016; ETH Zurich ASL)")
TUM_DATASET = ("TUM RGB-D benchmark (Sturm et al., \"A Benchmark for the Evaluation of RGB-D SLAM "
               "Systems\", IROS 2012; TU Munich)")

RPG_GT_NOTE = ("The estimate's own folder in rpg_trajectory_evaluation has a `stamped_groundtruth.txt`, "
               "but that file is over 4 MiB and is not in the stored snapshot of the repository; the "
               "ground truth is therefore read from OpenVINS' copy of the EuRoC ground truth, whose "
               "values equal rpg's wherever both are available (checked on MH_04 and V1_02 below).")

SEQUENCES = [
    {
        "name": "euroc_mh03_vio_stereo",
        "short_estimator": "`vio_stereo` (stereo VIO)",
        "dataset": "EuRoC MH_03_medium (machine hall, Leica laser-tracker + motion-capture ground truth)",
        "estimator": "`vio_stereo` of rpg_trajectory_evaluation's example results: a stereo "
                     "visual-inertial odometry, not named by the repository",
        "metric_scale": True,
        "est": ("rpg", f"{RPG_EUROC}/vio_stereo/laptop_vio_stereo_MH_03/stamped_traj_estimate.txt", "tum"),
        "gt": ("openvins", f"{OV}/MH_03_medium.txt", "tum"),
        "notes": [RPG_GT_NOTE, "OpenVINS' `MH_03_medium.csv` (full nanosecond stamps) is not in the "
                  "snapshot either (over 4 MiB); its `.txt` twin rounds stamps to 10 us, values to 1e-6."],
    },
    {
        "name": "euroc_mh05_vio_mono",
        "short_estimator": "`vio_mono` (monocular VIO)",
        "dataset": "EuRoC MH_05_difficult (machine hall)",
        "estimator": "`vio_mono` of rpg_trajectory_evaluation's example results: a monocular "
                     "visual-inertial odometry (metric scale from the IMU), not named by the repository",
        "metric_scale": True,
        "est": ("rpg", f"{RPG_EUROC}/vio_mono/laptop_vio_mono_MH_05/stamped_traj_estimate.txt", "tum"),
        "gt": ("openvins", f"{OV}/MH_05_difficult.csv", "euroc_csv"),
        "notes": [RPG_GT_NOTE],
    },
    {
        "name": "euroc_v203_vio_mono",
        "short_estimator": "`vio_mono` (monocular VIO)",
        "dataset": "EuRoC V2_03_difficult (Vicon room 2, motion-capture ground truth)",
        "estimator": "`vio_mono` of rpg_trajectory_evaluation's example results (as euroc_mh05_vio_mono)",
        "metric_scale": True,
        "est": ("rpg", f"{RPG_EUROC}/vio_mono/laptop_vio_mono_V2_03/stamped_traj_estimate.txt", "tum"),
        "gt": ("openvins", f"{OV}/V2_03_difficult.csv", "euroc_csv"),
        "notes": [RPG_GT_NOTE, "The sequence with clearly visible drift: several decimetres of "
                  "position error and a scale about 10 % off (see the Sim(3) scale)."],
    },
    {
        "name": "euroc_mh01_vio_mono",
        "short_estimator": "`vio_mono` (monocular VIO)",
        "dataset": "EuRoC MH_01_easy (machine hall)",
        "estimator": "`vio_mono` of rpg_trajectory_evaluation's example results (as euroc_mh05_vio_mono)",
        "metric_scale": True,
        "est": ("rpg", f"{RPG_EUROC}/vio_mono/laptop_vio_mono_MH_01/stamped_traj_estimate.txt", "tum"),
        "gt": ("openvins", f"{OV}/MH_01_easy.txt", "tum"),
        "notes": [RPG_GT_NOTE, "The longest duration here; slow scale drift (Sim(3) scale about 1.04). "
                  "OpenVINS' `MH_01_easy.csv` is not in the snapshot (over 4 MiB); its `.txt` twin "
                  "rounds stamps to 10 us."],
    },
    {
        "name": "euroc_mh04_vislam_rp",
        "short_estimator": "`vislam_rp` (monocular VI-SLAM, real-time poses)",
        "dataset": "EuRoC MH_04_difficult (machine hall)",
        "estimator": "`vislam_rp` of rpg_trajectory_evaluation's example results: the real-time poses "
                     "of a monocular visual-inertial SLAM, not named by the repository; trial 0 of its 10",
        "metric_scale": True,
        "est": ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_MH_04/stamped_traj_estimate0.txt", "tum"),
        # Trial 1 of the same estimator on the same recording: the odometry of a
        # "later drive" of the same path with drift of its own (scripts/bench_update.sh).
        "later_est": ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_MH_04/stamped_traj_estimate1.txt", "tum"),
        "gt": ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_MH_04/stamped_groundtruth.txt", "tum"),
        "notes": ["Estimate and ground truth come from the same folder of the same repository. "
                  "The estimate starts well after the ground truth (the SLAM's initialisation)."],
    },
    {
        "name": "tum_fr2_desk_orbslam_mono",
        "short_estimator": "ORB-SLAM monocular keyframes (arbitrary scale)",
        "dataset": "TUM RGB-D fr2/desk (`rgbd_dataset_freiburg2_desk`, motion-capture ground truth "
                   "of the Kinect's colour camera)",
        "estimator": "ORB-SLAM, MONOCULAR, keyframe trajectory (`fr2_desk_ORB_kf_mono.txt` in evo's "
                     "test data; evo does not state the ORB-SLAM version). Arbitrary scale: its unit is "
                     "not the metre",
        "metric_scale": False,
        "est": ("evo", "test/data/fr2_desk_ORB_kf_mono.txt", "tum"),
        "gt": ("evo", "test/data/fr2_desk_groundtruth.txt", "tum"),
        "notes": ["Only keyframes (about 1.7 Hz on average, irregular). The ground truth of this "
                  "sequence has a gap of about 12 s with no poses; estimate poses with no ground truth "
                  "within 20 ms are not counted in the ATE. evo's `fr2_desk_ORB.txt` is NOT monocular "
                  "(its Sim(3) scale is 0.997, i.e. metric: RGB-D or stereo) and is not used."],
    },
]

# GT files that exist in two sources: used to show the sources agree (not written out).
GT_CROSS_CHECKS = [
    ("MH_04", ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_MH_04/stamped_groundtruth.txt", "tum"),
     ("openvins", f"{OV}/MH_04_difficult.csv", "euroc_csv")),
    ("MH_04", ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_MH_04/stamped_groundtruth.txt", "tum"),
     ("openvins", f"{OV}/MH_04_difficult.txt", "tum")),
    ("V1_02", ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_V1_02/stamped_groundtruth.txt", "tum"),
     ("openvins", f"{OV}/V1_02_medium.csv", "euroc_csv")),
    ("V1_02", ("rpg", f"{RPG_VISLAM}/vislam_rp/laptop_vislam_rp_V1_02/stamped_groundtruth.txt", "tum"),
     ("openvins", f"{OV}/V1_02_medium.txt", "tum")),
    ("MH_05", ("openvins", f"{OV}/MH_05_difficult.csv", "euroc_csv"),
     ("openvins", f"{OV}/MH_05_difficult.txt", "tum")),
    ("V2_03", ("openvins", f"{OV}/V2_03_difficult.csv", "euroc_csv"),
     ("openvins", f"{OV}/V2_03_difficult.txt", "tum")),
]


# --------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------
class Mirrors:
    def __init__(self, dirs):
        self.dirs = dirs

    def _git(self, key, *args):
        return subprocess.run(["git", "--git-dir=" + self.dirs[key], *args], check=True,
                              capture_output=True, text=True).stdout

    def show(self, key, path):
        commit = REPOS[key]["commit"]
        try:
            return self._git(key, "show", f"{commit}:{path}")
        except subprocess.CalledProcessError as e:
            sys.exit(f"error: cannot read {REPOS[key]['name']}@{commit}:{path} from "
                     f"{self.dirs[key]}: {e.stderr.strip()}")

    def blob(self, key, path):
        return self._git(key, "rev-parse", f"{REPOS[key]['commit']}:{path}").strip()


class Pose:
    __slots__ = ("t", "tf", "v")

    def __init__(self, t, v):
        self.t = t            # decimal.Decimal, exact as published
        self.tf = float(t)    # for arithmetic
        self.v = v            # [tx, ty, tz, qx, qy, qz, qw] floats


def parse(text, fmt):
    poses = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line[0] == "#":
            continue
        if fmt == "tum":
            tok = line.split()
            if len(tok) != 8:
                raise ValueError(f"expected 8 values, got {len(tok)}: {line[:80]}")
            t = decimal.Decimal(tok[0])
            v = [float(x) for x in tok[1:]]
        elif fmt == "euroc_csv":
            # timestamp[ns], p_RS_R x y z, q_RS w x y z, (velocity, biases ignored)
            tok = line.split(",")
            t = decimal.Decimal(int(tok[0])).scaleb(-9)
            p = [float(x) for x in tok[1:8]]
            v = [p[0], p[1], p[2], p[4], p[5], p[6], p[3]]
        else:
            raise ValueError(fmt)
        poses.append(Pose(t, v))
    poses.sort(key=lambda p: p.t)
    return poses


# --------------------------------------------------------------------------------------
# Selection (clip + decimate, original samples only)
# --------------------------------------------------------------------------------------
def decimate_estimate(est, t0, t1, period):
    kept, last = [], None
    for p in est:
        if p.t < t0 or p.t > t1:
            continue
        if last is None or p.tf - last >= float(period) - SPACING_TOLERANCE:
            kept.append(p)
            last = p.tf
    return kept


def nearest(times, t):
    i = bisect.bisect_left(times, t)
    best = None
    for j in (i - 1, i):
        if 0 <= j < len(times) and (best is None or abs(times[j] - t) < abs(times[best] - t)):
            best = j
    return best


def decimate_groundtruth(gt, t0, t1, period, est_kept):
    """Original GT samples: the nearest to each kept estimate time (<= ASSOC_MAX_DT), then, where
    the estimate leaves a hole, the nearest to each point of a regular grid of the same period
    (only if it is at least one period, less 1 ms, away from every pose already kept)."""
    inside = [p for p in gt if t0 <= p.t <= t1]
    times = [p.tf for p in inside]
    chosen = set()
    for p in est_kept:
        j = nearest(times, p.tf)
        if j is not None and abs(times[j] - p.tf) <= ASSOC_MAX_DT:
            chosen.add(j)
    chosen_times = sorted(times[j] for j in chosen)
    half = float(period) / 2
    anchor = est_kept[0].t
    k = -int((anchor - t0) / period)
    while True:
        g = anchor + k * period
        if g > t1:
            break
        k += 1
        if g < t0:
            continue
        gf = float(g)
        j = nearest(times, gf)
        if j is None or abs(times[j] - gf) > half or j in chosen:
            continue
        c = nearest(chosen_times, times[j])
        if c is not None and abs(chosen_times[c] - times[j]) < float(period) - SPACING_TOLERANCE:
            continue  # too close to a kept pose: the rate cap holds for the filled-in poses too
        chosen.add(j)
        bisect.insort(chosen_times, times[j])
    return [inside[j] for j in sorted(chosen)], inside


# --------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------
def fmt_t(t):
    return format(t.quantize(NS, rounding=decimal.ROUND_HALF_EVEN), "f")


def render(header, poses):
    lines = [header]
    prev = None
    for p in poses:
        ts = fmt_t(p.t)
        if prev is not None and decimal.Decimal(ts) <= prev:
            raise ValueError(f"timestamps not strictly increasing after formatting: {ts}")
        prev = decimal.Decimal(ts)
        lines.append(ts + " " + " ".join(f"{x:.6f}" for x in p.v[:3]) + " "
                     + " ".join(f"{x:.9f}" for x in p.v[3:]))
    return "\n".join(lines) + "\n"


def header_line(key, path, what):
    r = REPOS[key]
    return f"# {r['name']}@{r['commit']} {path} (derived: {what})"


# --------------------------------------------------------------------------------------
# Geometry (pure Python: Horn's quaternion method == Umeyama's optimum, proper rotation)
# --------------------------------------------------------------------------------------
def _jacobi_eig_sym(a):
    n = len(a)
    a = [row[:] for row in a]
    v = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    for _ in range(100):
        if sum(a[i][j] ** 2 for i in range(n) for j in range(n) if i != j) < 1e-30:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if a[p][q] == 0.0:
                    continue
                th = (a[q][q] - a[p][p]) / (2 * a[p][q])
                t = (1.0 if th >= 0 else -1.0) / (abs(th) + math.sqrt(th * th + 1))
                c = 1 / math.sqrt(t * t + 1)
                s = t * c
                for k in range(n):
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = v[k][p], v[k][q]
                    v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    return [a[i][i] for i in range(n)], v


def quat_to_matrix(qx, qy, qz, qw):
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def umeyama(xs, ys, with_scale):
    """s, R, t minimising sum |y - (s R x + t)|^2."""
    n = len(xs)
    mx = [sum(p[k] for p in xs) / n for k in range(3)]
    my = [sum(p[k] for p in ys) / n for k in range(3)]
    xc = [[p[k] - mx[k] for k in range(3)] for p in xs]
    yc = [[p[k] - my[k] for k in range(3)] for p in ys]
    s_ = [[sum(a[i] * b[j] for a, b in zip(xc, yc)) for j in range(3)] for i in range(3)]
    (sxx, sxy, sxz), (syx, syy, syz), (szx, szy, szz) = s_
    nmat = [[sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
            [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
            [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
            [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz]]
    ev, vec = _jacobi_eig_sym(nmat)
    i = max(range(4), key=lambda k: ev[k])
    w, x, y, z = (vec[k][i] for k in range(4))
    rot = quat_to_matrix(x, y, z, w)
    scale = 1.0
    if with_scale:
        num = sum(b[r] * sum(rot[r][c] * a[c] for c in range(3)) for a, b in zip(xc, yc) for r in range(3))
        scale = num / sum(a[0] ** 2 + a[1] ** 2 + a[2] ** 2 for a in xc)
    t = [my[r] - scale * sum(rot[r][c] * mx[c] for c in range(3)) for r in range(3)]
    return scale, rot, t


def apply(scale, rot, t, p):
    return [scale * sum(rot[r][c] * p[c] for c in range(3)) + t[r] for r in range(3)]


def ate(pairs, with_scale, fit_count=None):
    """RMSE/max position error after alignment on the first fit_count pairs (all by default)."""
    xs = [e.v[:3] for e, _ in pairs]
    ys = [g.v[:3] for _, g in pairs]
    m = fit_count or len(pairs)
    scale, rot, t = umeyama(xs[:m], ys[:m], with_scale)
    errs = [math.dist(apply(scale, rot, t, x), y) for x, y in zip(xs, ys)]
    # orientation error after the alignment's rotation (same body frame assumed)
    angs = []
    for e, g in pairs:
        r_e = matmul(rot, quat_to_matrix(*e.v[3:]))
        r_d = matmul(transpose(quat_to_matrix(*g.v[3:])), r_e)
        c = max(-1.0, min(1.0, (r_d[0][0] + r_d[1][1] + r_d[2][2] - 1) / 2))
        angs.append(math.degrees(math.acos(c)))
    return {"rmse": math.sqrt(sum(e * e for e in errs) / len(errs)), "max": max(errs),
            "end": errs[-1], "scale": scale,
            "rot_rmse_deg": math.sqrt(sum(a * a for a in angs) / len(angs))}


def path_length(poses):
    return sum(math.dist(poses[i].v[:3], poses[i + 1].v[:3]) for i in range(len(poses) - 1))


def associate(est, gt):
    times = [g.tf for g in gt]
    pairs = []
    for e in est:
        j = nearest(times, e.tf)
        if j is not None and abs(times[j] - e.tf) <= ASSOC_MAX_DT:
            pairs.append((e, gt[j]))
    return pairs


# --------------------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------------------
def derive(m, spec, out_dir):
    ek, epath, efmt = spec["est"]
    gk, gpath, gfmt = spec["gt"]
    est = parse(m.show(ek, epath), efmt)
    gt = parse(m.show(gk, gpath), gfmt)
    s0 = max(est[0].t, gt[0].t)
    s1 = min(est[-1].t, gt[-1].t)
    t0, t1 = s0 - CLIP_TOLERANCE, s1 + CLIP_TOLERANCE
    span = f"[{fmt_t(s0)}, {fmt_t(s1)}] s (+-{CLIP_TOLERANCE.normalize()} s)"
    n_est_span = sum(1 for p in est if t0 <= p.t <= t1)

    k_est = 1
    while True:
        period = BASE_PERIOD * k_est
        est_kept = decimate_estimate(est, t0, t1, period)
        est_hdr = header_line(ek, epath, (
            f"clipped to {span} where ground truth exists; kept original samples "
            f"spaced >= {period.normalize()} s (<= {float(1 / period):.3g} Hz): {len(est_kept)} of {n_est_span}; "
            f"no interpolation, no alignment, no rescaling; re-printed with 9/6/9 decimals"))
        est_text = render(est_hdr, est_kept)
        if len(est_text.encode()) <= SIZE_LIMIT:
            break
        k_est += 1

    k_gt = k_est
    while True:
        period_gt = BASE_PERIOD * k_gt
        gt_kept, gt_inside = decimate_groundtruth(gt, t0, t1, period_gt, est_kept)
        gt_hdr = header_line(gk, gpath, (
            f"clipped to {span} where the estimate exists; kept original samples: "
            f"nearest (<= {ASSOC_MAX_DT} s) to each kept estimate time, and in the estimate's holes, "
            f"nearest to a {period_gt.normalize()} s grid, spaced >= {period_gt.normalize()} s: {len(gt_kept)} of {len(gt_inside)}; "
            f"no interpolation; {'EuRoC csv (ns, q_w first) converted to TUM order; ' if gfmt == 'euroc_csv' else ''}"
            f"re-printed with 9/6/9 decimals"))
        gt_text = render(gt_hdr, gt_kept)
        if len(gt_text.encode()) <= SIZE_LIMIT:
            break
        k_gt += 1

    # quaternion sanity (the project's reader rejects |q| off by more than 1e-3)
    qdev = max(abs(math.sqrt(sum(x * x for x in p.v[3:])) - 1) for p in est_kept + gt_kept)
    if qdev > 1e-3:
        raise ValueError(f"{spec['name']}: quaternion norm off by {qdev}")

    d = os.path.join(out_dir, spec["name"])
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "estimate.tum"), "w") as f:
        f.write(est_text)
    with open(os.path.join(d, "groundtruth.tum"), "w") as f:
        f.write(gt_text)

    if "later_est" in spec:
        lk, lpath, lfmt = spec["later_est"]
        later = decimate_estimate(parse(m.show(lk, lpath), lfmt), t0, t1, period)
        with open(os.path.join(d, "estimate_later.tum"), "w") as f:
            f.write(render(header_line(lk, lpath, (
                f"another trial of the same estimator on the same recording (a later drive's "
                f"odometry); clipped to {span}; kept original samples spaced >= "
                f"{period.normalize()} s: {len(later)}; no interpolation, no alignment, no "
                f"rescaling; re-printed with 9/6/9 decimals")), later))

    # measured facts, on the written (derived) files
    pairs = associate(est_kept, gt_kept)
    pairs_full = associate(est_kept, gt_inside)
    assert len(pairs) == len(pairs_full), "a kept estimate pose lost its ground-truth partner"
    se3 = ate(pairs, False)
    sim3 = ate(pairs, True)
    n10 = max(10, len(pairs) // 10)
    drift = ate(pairs, not spec["metric_scale"], fit_count=n10)
    return {
        "spec": spec, "t0": s0, "t1": s1,
        "duration": float(s1 - s0),
        "est_src_span": (est[0].t, est[-1].t), "gt_src_span": (gt[0].t, gt[-1].t),
        "n_est": len(est_kept), "n_est_span": n_est_span, "n_est_src": len(est),
        "n_gt": len(gt_kept), "n_gt_span": len(gt_inside), "n_gt_src": len(gt),
        "rate_est": float(1 / (BASE_PERIOD * k_est)), "rate_gt": float(1 / (BASE_PERIOD * k_gt)),
        "bytes_est": len(est_text.encode()), "bytes_gt": len(gt_text.encode()),
        "gt_len_full": path_length(gt_inside), "gt_len": path_length(gt_kept),
        "est_len": path_length(est_kept),
        "pairs": len(pairs), "max_pair_dt": max(abs(e.tf - g.tf) for e, g in pairs),
        "se3": se3, "sim3": sim3, "drift": drift, "drift_fit": n10, "qdev": qdev,
        "blob_est": m.blob(ek, epath), "blob_gt": m.blob(gk, gpath),
    }


def cross_check(m):
    rows = []
    for seq, a, b in GT_CROSS_CHECKS:
        pa = parse(m.show(*a[:2]), a[2])
        pb = parse(m.show(*b[:2]), b[2])
        tb = [p.tf for p in pb]
        matched, dt, dv = 0, 0.0, 0.0
        for p in pa:
            j = nearest(tb, p.tf)
            if j is not None and abs(tb[j] - p.tf) < 1e-4:
                matched += 1
                dt = max(dt, abs(tb[j] - p.tf))
                dv = max(dv, max(abs(x - y) for x, y in zip(p.v, pb[j].v)))
        rows.append((seq, a, b, len(pa), len(pb), matched, dt, dv))
    return rows


def rel(d, pos, neg):
    return f"{abs(float(d)):.2f} s {pos if d >= 0 else neg}"


def f3(x):
    return f"{x:.3f}"


def readme(results, checks, m):
    L = []
    w = L.append
    w("# Real odometry / SLAM trajectories with ground truth")
    w("")
    w("Small TUM files (`t tx ty tz qx qy qz qw`; seconds, metres, unit quaternions) of REAL estimates "
      "published by others, each with its ground truth, to test how the joint adjustment copes with "
      "real drift. The estimates are NOT aligned, rescaled or smoothed: only clipped in time, "
      "decimated by keeping original samples, and re-printed with 9/6/9 decimals. Every file's first "
      "line names its source repository, commit, path and what was done.")
    w("")
    w("Generated by `scripts/derive_real_trajectories.py` (Python 3 standard library only) from bare git "
      "mirrors of the source repositories, read with `git show <commit>:<path>`:")
    w("")
    w("```")
    w("python3 scripts/derive_real_trajectories.py \\")
    w("    --rpg      <mirror of uzh-rpg/rpg_trajectory_evaluation> \\")
    w("    --openvins <mirror of rpng/open_vins> \\")
    w("    --evo      <mirror of MichaelGrupp/evo> \\")
    w("    --out      <this folder>")
    w("```")
    w("")
    w("## Summary (measured by the script on the files in this folder)")
    w("")
    w("| folder | dataset | estimator | GT path (m) | duration (s) | poses est / GT | ATE RMSE SE(3) (m) | ATE RMSE Sim(3) (m) | Sim(3) scale |")
    w("|---|---|---|---|---|---|---|---|---|")
    for r in results:
        s = r["spec"]
        w(f"| `{s['name']}` | {s['dataset'].split(' (')[0]} | {s['short_estimator']} | {r['gt_len_full']:.1f} | "
          f"{r['duration']:.1f} | {r['n_est']} / {r['n_gt']} | "
          f"{f3(r['se3']['rmse'])}{'' if s['metric_scale'] else ' (meaningless: unknown scale)'} | "
          f"{f3(r['sim3']['rmse'])} | {r['sim3']['scale']:.4f} |")
    w("")
    w("ATE: each estimate pose is paired with the ground-truth pose nearest in time (at most "
      f"{ASSOC_MAX_DT} s away, in the files here), the estimate's positions are aligned to the ground "
      "truth's by the least-squares rigid (SE(3)) or similarity (Sim(3)) transform over all pairs "
      "(Umeyama / Horn), and the RMSE of the remaining position differences is reported. For the "
      "monocular estimate only the Sim(3) figure means anything. \"GT path\" is the length of the "
      "full-rate ground truth over the kept time span.")
    w("")
    w("## Per sequence")
    for r in results:
        s = r["spec"]
        ek, epath, efmt = s["est"]
        gk, gpath, gfmt = s["gt"]
        w("")
        w(f"### `{s['name']}`")
        w("")
        w(f"- Dataset: {s['dataset']}.")
        w(f"- Estimator: {s['estimator']}.")
        w(f"- Estimate source: `{REPOS[ek]['name']}` @ `{REPOS[ek]['commit']}`, `{epath}` (blob `{r['blob_est']}`).")
        if "later_est" in s:
            w(f"- estimate_later.tum: another trial of the same estimator on the same recording, "
              f"`{s['later_est'][1]}`, clipped and decimated as estimate.tum: the odometry of a later "
              f"drive of the same path (`scripts/bench_update.sh`).")
        w(f"- Ground-truth source: `{REPOS[gk]['name']}` @ `{REPOS[gk]['commit']}`, `{gpath}` (blob `{r['blob_gt']}`)"
          f"{', EuRoC csv format' if gfmt == 'euroc_csv' else ''}.")
        es, gs = r["est_src_span"], r["gt_src_span"]
        w(f"- Time span kept: {fmt_t(r['t0'])} .. {fmt_t(r['t1'])} s = {r['duration']:.2f} s "
          f"(source estimate {fmt_t(es[0])} .. {fmt_t(es[1])}, source ground truth {fmt_t(gs[0])} .. "
          f"{fmt_t(gs[1])}: the estimate starts {rel(es[0] - gs[0], 'after', 'before')} the ground truth "
          f"and ends {rel(gs[1] - es[1], 'before', 'after')} it).")
        w(f"- estimate.tum: {r['n_est']} poses (of {r['n_est_span']} in the span, {r['n_est_src']} in the source), "
          f"spacing >= {1 / r['rate_est']:.3g} s (<= {r['rate_est']:.3g} Hz), {r['bytes_est']} bytes.")
        w(f"- groundtruth.tum: {r['n_gt']} poses (of {r['n_gt_span']} in the span, {r['n_gt_src']} in the source): "
          f"at the estimate's times, its holes filled from a {1 / r['rate_gt']:.3g} s grid, {r['bytes_gt']} bytes.")
        w(f"- Ground-truth path length: {r['gt_len_full']:.2f} m at full rate over the span "
          f"({r['gt_len']:.2f} m through the kept poses). Estimate path length: {r['est_len']:.2f} "
          f"{'m' if s['metric_scale'] else 'estimate units'}.")
        w(f"- Pairs for ATE: {r['pairs']} of {r['n_est']} estimate poses (largest time offset "
          f"{r['max_pair_dt'] * 1000:.3f} ms).")
        w(f"- ATE after SE(3) alignment: RMSE {r['se3']['rmse']:.4f} m, max {r['se3']['max']:.4f} m; "
          f"orientation RMSE {r['se3']['rot_rmse_deg']:.2f} deg.")
        w(f"- ATE after Sim(3) alignment: RMSE {r['sim3']['rmse']:.4f} m, max {r['sim3']['max']:.4f} m, "
          f"scale {r['sim3']['scale']:.4f} (ground-truth metres per estimate unit).")
        kind = "SE(3)" if s["metric_scale"] else "Sim(3)"
        w(f"- Drift indicator: aligned ({kind}) on the first {r['drift_fit']} pairs only, the last pose is "
          f"{r['drift']['end']:.3f} m off (RMSE over all pairs {r['drift']['rmse']:.3f} m).")
        w(f"- Largest deviation of a quaternion's norm from 1 in the files: {r['qdev']:.1e}.")
        for n in s.get("notes", []):
            w(f"- {n}")
    w("")
    w("## Ground-truth sources agree")
    w("")
    w("EuRoC ground truth appears in several repositories; where two copies are available they were "
      "compared pose by pose (same time within 0.1 ms):")
    w("")
    w("| sequence | copy A | copy B | poses A / B | matched | max time diff (s) | max value diff |")
    w("|---|---|---|---|---|---|---|")
    for seq, a, b, na, nb, matched, dt, dv in checks:
        w(f"| {seq} | `{REPOS[a[0]]['name']}` `{a[1]}` | `{REPOS[b[0]]['name']}` `{b[1]}` | {na} / {nb} | "
          f"{matched} | {dt:.1e} | {dv:.1e} |")
    w("")
    w("## Frames")
    w("")
    w("- EuRoC: the ground truth is the pose of the MAV's body (IMU) frame in the motion-capture / "
      "laser-tracker world frame (`state_groundtruth_estimate0`, p_RS_R, q_RS). The rpg estimates are "
      "poses of the same body frame in the estimator's own world frame (orientation RMSE after "
      "alignment is a few degrees, see above), with the start offset and yaw unknown: align before "
      "comparing.")
    w("- TUM fr2/desk: the ground truth is the pose of the Kinect colour camera's optical centre in the "
      "motion-capture frame; the ORB-SLAM estimate is the camera pose in the first keyframe's frame, "
      "with an arbitrary scale.")
    w("")
    w("## Licences found")
    w("")
    w("Repositories (read from their files at the pinned commits):")
    w("")
    for key, r in REPOS.items():
        w(f"- `{r['name']}` @ `{r['commit']}`: {r['licence']}")
    w("")
    w("Datasets:")
    w("")
    w(f"- {EUROC_DATASET}: no licence or terms of use for the EuRoC data were found in any of the three "
      "repositories, nor in the reference material searched while preparing these files (the dataset "
      "page itself could not be consulted). The terms are UNVERIFIED: nothing found forbids "
      "redistribution, but nothing found grants it either. Cite the paper when using the data.")
    w(f"- {TUM_DATASET}: the benchmark's web site is quoted (in a third-party note; the site itself was "
      "not consulted) as: \"Unless stated otherwise, all data in the TUM RGB-D benchmark is licensed "
      "under a Creative Commons 4.0 Attribution License (CC BY 4.0) and the accompanying source code is "
      "licensed under a BSD-2-Clause License.\" CC BY 4.0 allows redistribution with attribution and "
      "an indication of changes (given here and in each file's first line).")
    w("- The estimates themselves were produced by the repositories' authors (rpg: anonymous VIO / "
      "VI-SLAM runs; evo: ORB-SLAM run); they carry the licence of the repository they are published in.")
    w("")
    return "\n".join(L)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rpg", required=True, help="bare git dir of uzh-rpg/rpg_trajectory_evaluation")
    ap.add_argument("--openvins", required=True, help="bare git dir of rpng/open_vins")
    ap.add_argument("--evo", required=True, help="bare git dir of MichaelGrupp/evo")
    ap.add_argument("--out", required=True, help="output folder (one sub-folder per sequence + README.md)")
    args = ap.parse_args()
    m = Mirrors({"rpg": args.rpg, "openvins": args.openvins, "evo": args.evo})
    os.makedirs(args.out, exist_ok=True)
    results = []
    for spec in SEQUENCES:
        r = derive(m, spec, args.out)
        results.append(r)
        print(f"{spec['name']:28s} {r['gt_len_full']:7.2f} m {r['duration']:7.2f} s "
              f"est {r['n_est']:5d} ({r['rate_est']:.3g} Hz, {r['bytes_est']} B) gt {r['n_gt']:5d} "
              f"({r['bytes_gt']} B)  ATE se3 {r['se3']['rmse']:.4f} m  sim3 {r['sim3']['rmse']:.4f} m "
              f"s={r['sim3']['scale']:.4f}  end-drift {r['drift']['end']:.3f} m")
    checks = cross_check(m)
    for c in checks:
        print(f"cross-check {c[0]}: {c[1][1]} vs {c[2][1]}: matched {c[5]} of {c[3]}/{c[4]}, "
              f"max dt {c[6]:.1e} s, max value diff {c[7]:.1e}")
    with open(os.path.join(args.out, "README.md"), "w") as f:
        f.write(readme(results, checks, m))
    print("wrote", args.out)


if __name__ == "__main__":
    main()
