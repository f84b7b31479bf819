#!/usr/bin/env python3
"""The floor of any import that stores one image file per frame (doc/benchmarks.md, ROS 2 bag
import): writing N frames of S bytes as N files against writing them as one file and against
`cp` of that file, in the same run, in the current folder's file system.

    bench_file_floor.py [frames, default 800] [bytes per frame, default 340000]
"""
import os
import subprocess
import sys
import tempfile
import time

frames = int(sys.argv[1]) if len(sys.argv) > 1 else 800
size = int(sys.argv[2]) if len(sys.argv) > 2 else 340_000
data = os.urandom(size)


def once(work):
    """Seconds for: one file, one file per frame, cp of the one file."""
    subprocess.run(["sync"], check=True)  # no earlier dirty pages throttling this run
    start = time.time()
    with open(os.path.join(work, "one.bin"), "wb") as f:
        for _ in range(frames):
            f.write(data)
    one = time.time() - start
    os.makedirs(os.path.join(work, "many"))
    start = time.time()
    for i in range(frames):
        with open(os.path.join(work, "many", f"{i}.png"), "wb") as f:
            f.write(data)
    many = time.time() - start
    start = time.time()
    subprocess.run(["cp", os.path.join(work, "one.bin"), os.path.join(work, "copy.bin")], check=True)
    return one, many, time.time() - start


runs = []
for _ in range(5):
    with tempfile.TemporaryDirectory(dir=".") as work:
        runs.append(once(work))
one, many, cp = (sorted(r[k] for r in runs)[2] for k in range(3))
print(f"{frames} frames of {size} bytes, medians of 5: one file {one:.3f} s, one file per frame "
      f"{many:.3f} s, cp of the one file {cp:.3f} s; files per frame / cp = {many / cp:.2f}")
