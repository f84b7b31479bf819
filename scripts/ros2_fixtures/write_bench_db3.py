#!/usr/bin/env python3
"""Puts the CDR messages that write_bench.mjs framed into <name>.msgs into a
rosbag2 sqlite3 file (Humble schema), for scripts/bench_ros2_import.sh; the
.db3 bag then holds exactly the messages of the MCAP bags.
Usage: write_bench_db3.py <name>.msgs <out.db3>
"""
import sqlite3
import struct
import sys

from write_db3 import SCHEMA  # the fixtures' rosbag2 schema, one copy

TOPICS = [("/fisheye/image/compressed", "sensor_msgs/msg/CompressedImage"),
          ("/cam/image_raw", "sensor_msgs/msg/Image"),
          ("/odom", "nav_msgs/msg/Odometry")]


def messages(path):
    with open(path, "rb") as f:
        while head := f.read(13):
            topic, log_time, size = struct.unpack("<BQI", head)
            yield topic + 1, log_time, f.read(size)


def main():
    db = sqlite3.connect(sys.argv[2])
    # rosbag2's own write settings: no journal file, no fsync.
    db.execute("PRAGMA journal_mode = MEMORY")
    db.execute("PRAGMA synchronous = OFF")
    db.executescript(SCHEMA)
    db.execute("INSERT INTO schema VALUES (3, 'humble')")
    db.executemany("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')",
                   [(i + 1, name, type_) for i, (name, type_) in enumerate(TOPICS)])
    db.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", messages(sys.argv[1]))
    db.commit()
    db.close()


if __name__ == "__main__":
    main()
