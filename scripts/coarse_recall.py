#!/usr/bin/env python3
"""Recall of the coarse search against examining every frame, from two
`lookboth detect --out` folders: the markers (camera, time) the second finds
of those the first finds, and how many more. Used by the full-recording
benchmarks (scripts/bench_full_recording*.sh).

    coarse_recall.py <every-frame detect folder> <coarse detect folder> <label>
"""
import csv
import sys


def load(folder):
    with open(folder + "/detections/markers.csv") as f:
        return {(r["camera"], r["timestamp_ns"]) for r in csv.DictReader(f)}


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    every, coarse = load(sys.argv[1]), load(sys.argv[2])
    found = len(every & coarse)
    print(f"{sys.argv[3]}: the coarse search finds {found} of the {len(every)} markers examining "
          f"every frame finds ({100.0 * found / max(1, len(every)):.2f} %), and "
          f"{len(coarse - every)} more")


if __name__ == "__main__":
    main()
