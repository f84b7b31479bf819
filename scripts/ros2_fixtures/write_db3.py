#!/usr/bin/env python3
"""Writes the rosbag2 folders of tests/data/ros2 (called by scripts/make_ros2_fixtures.sh).

sample_db3/: rosbag2's sqlite3 schema (Humble) filled with the CDR blobs that
write_mcap.mjs serialized with @foxglove/rosmsg2-serialization
(db3_messages.json), inserted in a shuffled order so that the id order is not
the time order; and metadata.yaml for it and for sample_mcap_folder/ (two
MCAP files). Usage: write_db3.py <output folder>
"""
import base64
import json
import os
import sqlite3
import sys

import yaml

SCHEMA = """
CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                    serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
                      data BLOB NOT NULL);
CREATE INDEX timestamp_idx ON messages (timestamp ASC);
"""


def metadata(storage, files, messages):
    topics = {}
    for m in messages:
        topics.setdefault(m["topic"], {"type": m["type"], "count": 0})["count"] += 1
    times = [int(m["log_time"]) for m in messages]
    info = {
        "version": 5,
        "storage_identifier": storage,
        "duration": {"nanoseconds": max(times) - min(times)},
        "starting_time": {"nanoseconds_since_epoch": min(times)},
        "message_count": len(messages),
        "topics_with_message_count": [
            {"topic_metadata": {"name": name, "type": t["type"], "serialization_format": "cdr",
                                "offered_qos_profiles": ""},
             "message_count": t["count"]} for name, t in topics.items()],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": files,
        "files": [{"path": f} for f in files],
    }
    return yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False)


def write_db3(path, messages):
    db = sqlite3.connect(path)
    db.execute("PRAGMA page_size = 1024")  # a smaller file
    db.executescript(SCHEMA)
    db.execute("INSERT INTO schema VALUES (3, 'humble')")
    topic_ids = {}
    for m in messages:
        if m["topic"] not in topic_ids:
            topic_ids[m["topic"]] = len(topic_ids) + 1
            db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')",
                       (topic_ids[m["topic"]], m["topic"], m["type"]))
    # Pairs swapped: ids 1, 2, 3, 4 hold the messages 2, 1, 4, 3 of the time order.
    order = [i ^ 1 if (i ^ 1) < len(messages) else i for i in range(len(messages))]
    for i in order:
        m = messages[i]
        db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   (topic_ids[m["topic"]], int(m["log_time"]), base64.b64decode(m["cdr"])))
    db.commit()
    db.close()


def main():
    out = sys.argv[1]
    with open(os.path.join(out, "db3_messages.json")) as f:
        messages = json.load(f)
    split = json.load(open(os.path.join(out, "expected.json")))["split_after"]
    os.makedirs(os.path.join(out, "sample_db3"), exist_ok=True)
    write_db3(os.path.join(out, "sample_db3", "sample_db3_0.db3"), messages)
    with open(os.path.join(out, "sample_db3", "metadata.yaml"), "w") as f:
        f.write(metadata("sqlite3", ["sample_db3_0.db3"], messages))
    files = ["sample_mcap_folder_0.mcap", "sample_mcap_folder_1.mcap"]
    with open(os.path.join(out, "sample_mcap_folder", "metadata.yaml"), "w") as f:
        f.write(metadata("mcap", files, messages))
    assert split == 10


if __name__ == "__main__":
    main()
