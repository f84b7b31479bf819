#!/usr/bin/env python3
"""Replaces a camera folder's image frames (frames.csv + images) by one video
file, as a camera's recorder or NVR would have written it, with ffmpeg.

    frames_to_video.py <camera folder> [--timing container|sidecar] [--drop N,M,...]
                       [--codec libx264] [--crf 18] [--keyint N] [--bframes N]
                       [--no-scene-cuts] [--fragmented] [--keep-frames]

- container (default): the video's own timestamps carry the frame times
  (variable frame rate, microsecond time scale) and video.yaml holds the
  first frame's time (start_timestamp_ns).
- sidecar: video.csv lists every frame's timestamp_ns.
--drop removes those frames (0-based rows of frames.csv) from the video, as
a recorder that dropped them would: their times are missing, the others kept.
Used by the tests, the demo and the benchmarks (doc/formats.md, "Video files").
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile


def read_frames(folder):
    rows = []
    with open(os.path.join(folder, "frames.csv")) as f:
        lines = [l for l in f if l.strip() and not l.lstrip().startswith("#")]
    for row in csv.DictReader(lines):
        rows.append((int(row["timestamp_ns"].strip()), os.path.join(folder, row["file"].strip())))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--timing", choices=["container", "sidecar"], default="container")
    parser.add_argument("--drop", default="", help="frame rows to leave out, e.g. 5,6,7")
    parser.add_argument("--codec", default="libx264")
    parser.add_argument("--crf", default="18")
    parser.add_argument("--keyint", help="frames between key frames (the codec's default otherwise)")
    parser.add_argument("--bframes", help="B-frames in a row at most (the codec's default otherwise)")
    parser.add_argument("--no-scene-cuts", action="store_true",
                        help="key frames at the interval only, none where the picture changes")
    parser.add_argument("--fragmented", action="store_true",
                        help="a fragmented MP4 (readable up to where a recording was cut)")
    parser.add_argument("--keep-frames", action="store_true")
    args = parser.parse_args()

    frames = read_frames(args.folder)
    dropped = {int(x) for x in args.drop.split(",") if x}
    kept = [f for i, f in enumerate(frames) if i not in dropped]
    if len(kept) < 2:
        sys.exit(f"{args.folder}: fewer than 2 frames to encode")
    with tempfile.TemporaryDirectory() as tmp:
        listing = os.path.join(tmp, "frames.txt")
        with open(listing, "w") as f:
            f.write("ffconcat version 1.0\n")
            for i, (t, path) in enumerate(kept):
                f.write(f"file '{os.path.abspath(path)}'\n")
                # Each image read on a microsecond clock (image2's default, 25 Hz, would round the times).
                f.write("option framerate 1000000\n")
                # Each image lasts until the next frame: the video's timestamps are the frames'.
                if i + 1 < len(kept):
                    f.write(f"duration {(kept[i + 1][0] - t) / 1e9:.9f}\n")
        video = os.path.join(args.folder, "video.mp4")
        codec = ["-c:v", args.codec]
        if args.codec == "libx264":
            codec += ["-crf", args.crf, "-pix_fmt", "yuv420p"]
        if args.keyint:
            codec += ["-g", args.keyint]
        if args.bframes:
            codec += ["-bf", args.bframes]
        if args.no_scene_cuts:
            codec += ["-sc_threshold", "0"]
        if args.fragmented:
            codec += ["-movflags", "frag_keyframe+empty_moov"]
        subprocess.run(["ffmpeg", "-v", "error", "-y", "-f", "concat", "-safe", "0", "-i", listing,
                        "-fps_mode", "vfr", *codec, "-video_track_timescale", "1000000",
                        video], check=True)
    if args.timing == "container":
        with open(os.path.join(args.folder, "video.yaml"), "w") as f:
            f.write(f"start_timestamp_ns: {kept[0][0]}\n")
    else:
        with open(os.path.join(args.folder, "video.csv"), "w") as f:
            f.write("timestamp_ns\n")
            for t, _ in kept:
                f.write(f"{t}\n")
    if not args.keep_frames:
        os.remove(os.path.join(args.folder, "frames.csv"))
        shutil.rmtree(os.path.join(args.folder, "frames"), ignore_errors=True)


if __name__ == "__main__":
    main()
