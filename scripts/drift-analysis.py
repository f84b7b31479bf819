#!/usr/bin/env python3
"""How a real estimate's drift grows: relative pose error against distance and turn.

    scripts/drift-analysis.py <recordings dir> [segment length m]

For each recording (a folder with groundtruth.tum and estimate.tum, as
scripts/derive_real_trajectories.py writes them) the estimate's poses are
cut into consecutive stretches of the given length of path (default 1 m).
Over each stretch the relative pose error is taken as evo_rpe does: the
estimate's motion over the stretch against the ground truth's, each in the
stretch's first pose (the angle of the rotation error, and the position
error of the stretch's end), which holds whatever world frame each is in.
The stretches are then sorted by how much the body turned (the ground
truth's rotation angle over the stretch) and the RMS rotation error is
printed for the straight half and the turning half, with a least-squares
fit of
    rotation_error^2 = a^2 * length + b^2 * turn
which is the drift model a random walk in distance plus one in turn gives.
Standard library only (no numpy).
"""

import math
import os
import sys


def read_tum(path):
    poses = []
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        f = [float(x) for x in line.split()]
        poses.append((f[0], f[1:4], f[4:8]))
    return poses


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quat_conj(q):
    return (-q[0], -q[1], -q[2], q[3])


def rotate(q, v):
    p = quat_mul(quat_mul(q, (v[0], v[1], v[2], 0.0)), quat_conj(q))
    return p[:3]


def angle(q):
    """Rotation angle of a unit quaternion [rad], in [0, pi]."""
    return 2 * math.atan2(math.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2), abs(q[3]))


def interpolate(truth, t):
    """Ground truth at t (positions linear, orientation of the nearer sample)."""
    lo, hi = 0, len(truth) - 1
    if t < truth[0][0] or t > truth[-1][0]:
        return None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if truth[mid][0] <= t:
            lo = mid
        else:
            hi = mid
    t0, p0, q0 = truth[lo]
    t1, p1, q1 = truth[hi]
    a = 0.0 if t1 == t0 else (t - t0) / (t1 - t0)
    p = [p0[i] + a * (p1[i] - p0[i]) for i in range(3)]
    return p, (q0 if a < 0.5 else q1)


def stretches(truth, estimate, length):
    pairs = []
    for t, p, q in estimate:
        g = interpolate(truth, t)
        if g:
            pairs.append((p, q, g[0], g[1]))
    out, start, travelled = [], 0, 0.0
    for k in range(1, len(pairs)):
        travelled += math.dist(pairs[k][2][:2], pairs[k - 1][2][:2])
        if travelled >= length:
            ep0, eq0, gp0, gq0 = pairs[start]
            ep1, eq1, gp1, gq1 = pairs[k]
            # Each one's motion over the stretch in its first pose's frame:
            # frame-invariant, whatever world each is expressed in.
            rg = quat_mul(quat_conj(gq0), gq1)
            re = quat_mul(quat_conj(eq0), eq1)
            turn = angle(rg)
            rotation_error = angle(quat_mul(quat_conj(rg), re))
            de = rotate(quat_conj(eq0), [ep1[i] - ep0[i] for i in range(3)])
            dg = rotate(quat_conj(gq0), [gp1[i] - gp0[i] for i in range(3)])
            out.append((travelled, turn, rotation_error, math.dist(de, dg)))
            start, travelled = k, 0.0
    return out


def rms(values):
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else float('nan')


def main():
    root = sys.argv[1]
    length = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    print(f"stretches of {length:g} m; rotation error [deg], position error [cm]")
    for name in sorted(os.listdir(root)):
        d = os.path.join(root, name)
        if not os.path.isfile(os.path.join(d, 'estimate.tum')):
            continue
        s = stretches(read_tum(os.path.join(d, 'groundtruth.tum')),
                      read_tum(os.path.join(d, 'estimate.tum')), length)
        if len(s) < 4:
            continue
        s.sort(key=lambda x: x[1])
        half = len(s) // 2
        straight, turning = s[:half], s[half:]
        # Least squares for e^2 = A * length + B * |turn| (A, B >= 0 not enforced).
        sll = sum(x[0] * x[0] for x in s)
        stt = sum(x[1] * x[1] for x in s)
        slt = sum(x[0] * x[1] for x in s)
        sle = sum(x[0] * x[2] ** 2 for x in s)
        ste = sum(x[1] * x[2] ** 2 for x in s)
        det = sll * stt - slt * slt
        A = (sle * stt - ste * slt) / det
        B = (ste * sll - sle * slt) / det
        deg = 180 / math.pi
        print(f"{name:28s} {len(s):4d} stretches  rotation RMS straight "
              f"{rms([x[2] for x in straight]) * deg:6.3f} (turn "
              f"{rms([x[1] for x in straight]) * deg:5.1f})  turning "
              f"{rms([x[2] for x in turning]) * deg:6.3f} (turn "
              f"{rms([x[1] for x in turning]) * deg:5.1f})  position RMS straight "
              f"{rms([x[3] for x in straight]) * 100:5.2f} turning "
              f"{rms([x[3] for x in turning]) * 100:5.2f}  fit: a "
              f"{math.copysign(math.sqrt(abs(A)), A) * deg:6.3f} deg/sqrt(m), b "
              f"{math.copysign(math.sqrt(abs(B)), B) * deg:6.3f} deg/sqrt(rad)")


if __name__ == '__main__':
    main()
