#!/usr/bin/env python3
"""Play a folder dataset's fisheye recording N times back to back.

Makes a folder dataset (doc/formats.md) whose fisheye/frames.csv lists the
source's frames N times, each pass shifted by the recording's length plus one
frame period, and whose ground_truth/trajectory.tum is shifted alike. The
frames are referenced by absolute path, not copied; the environment cameras
are left out. For the odometry's memory benchmark on long runs
(doc/benchmarks.md), when the robot ends where it started.

usage: repeat-recording.py SOURCE_FOLDER TIMES OUT_FOLDER
"""
import os
import shutil
import sys


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__.strip().splitlines()[-1])
    src, times, out = os.path.abspath(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    if times < 1:
        sys.exit("TIMES must be at least 1")
    if os.path.exists(out):
        sys.exit(f"{out}: exists")
    frames_csv = os.path.join(src, "fisheye", "frames.csv")
    with open(frames_csv) as f:
        header = f.readline()
        rows = [line.rstrip("\n").split(",", 1) for line in f if line.strip()]
    if len(rows) < 2:
        sys.exit(f"{frames_csv}: fewer than two frames")
    stamps = [int(t) for t, _ in rows]
    period = (stamps[-1] - stamps[0]) // (len(stamps) - 1)
    shift = stamps[-1] - stamps[0] + period
    tmp = out + ".tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(os.path.join(tmp, "fisheye"))
    os.makedirs(os.path.join(tmp, "ground_truth"))
    shutil.copy(os.path.join(src, "marker.yaml"), tmp)
    shutil.copy(os.path.join(src, "fisheye", "calibration.yaml"), os.path.join(tmp, "fisheye"))
    with open(os.path.join(tmp, "fisheye", "frames.csv"), "w") as f:
        f.write(header)
        for n in range(times):
            for (t, name), stamp in zip(rows, stamps):
                path = name if os.path.isabs(name) else os.path.join(src, "fisheye", name)
                f.write(f"{stamp + n * shift},{path}\n")
    tum = os.path.join(src, "ground_truth", "trajectory.tum")
    with open(tum) as f:
        lines = [line for line in f if line.strip()]
    with open(os.path.join(tmp, "ground_truth", "trajectory.tum"), "w") as f:
        for line in lines:
            if line.startswith("#"):
                f.write(line)
        for n in range(times):
            for line in lines:
                if line.startswith("#"):
                    continue
                t, rest = line.split(" ", 1)
                sec, _, frac = t.partition(".")
                ns = int(sec) * 1_000_000_000 + int((frac + "000000000")[:9])
                ns += n * shift
                f.write(f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d} {rest}")
    os.rename(tmp, out)


if __name__ == "__main__":
    main()
