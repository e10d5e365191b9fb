#!/usr/bin/python3
"""usage: session_db3.py SESSION_DB3_JSON OUT_DB3

session_ros2.js's topics and CDR messages as a rosbag2 sqlite3 storage file,
with Python's sqlite3 and the tables rosbag2_storage_sqlite3 creates
(write_db3.py's, schema version 4: Iron and later, the message definitions in
their own table).
"""
import json
import sqlite3
import sys

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
from write_db3 import create_tables  # noqa: E402


def main():
    source, out = sys.argv[1:3]
    written = json.load(open(source))
    db = sqlite3.connect(out)
    create_tables(db, "jazzy")
    ids = {}
    for k, t in enumerate(written["topics"], start=1):
        ids[t["name"]] = k
        db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '', '')", (k, t["name"], t["type"]))
        db.execute("INSERT INTO message_definitions VALUES (?, ?, 'ros2msg', ?, '')",
                   (k, t["type"], t["definition"]))
    db.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   ((ids[m["topic"]], int(m["log_time"]), bytes.fromhex(m["data"])) for m in written["messages"]))
    db.commit()
    db.close()


main()
