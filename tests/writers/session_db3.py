#!/usr/bin/python3
"""usage: session_db3.py SESSION_DB3_JSON OUT_DB3

session_ros2.js's topics and CDR messages as a rosbag2 sqlite3 storage file,
with Python's sqlite3 and the tables rosbag2_storage_sqlite3 creates (schema
version 4: Iron and later, the message definitions in their own table; see
write_db3.py for the source).
"""
import json
import sqlite3
import sys


def main():
    source, out = sys.argv[1:3]
    written = json.load(open(source))
    db = sqlite3.connect(out)
    db.execute("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);")
    db.execute("CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,"
               "metadata TEXT NOT NULL);")
    db.execute("CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
               "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL,"
               " type_description_hash TEXT NOT NULL);")
    db.execute("CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT NULL,"
               "encoding TEXT NOT NULL,encoded_message_definition TEXT NOT NULL,"
               "type_description_hash TEXT NOT NULL);")
    db.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
               "timestamp INTEGER NOT NULL, data BLOB NOT NULL);")
    db.execute("CREATE INDEX timestamp_idx ON messages (timestamp ASC);")
    db.execute("INSERT INTO schema (schema_version, ros_distro) VALUES (4, 'jazzy')")
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
